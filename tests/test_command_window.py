"""The command window end to end: an answer that reached the robot before its cycle's window
closed counts, whatever the server's event loop is busy with at that moment.

The physics thread releases cycles, and reads the socket itself for an answer not yet read:
at a motion cycle's deadline, and in lockstep while it waits for the answer. Here the loop is
blocked on purpose while a raw client answers, so only those reads can see the answers.
Lockstep, so each window is 100 ms of wall time: the client has ample time to answer on a
loaded machine, and the outcome does not depend on timing.
"""

from __future__ import annotations

import asyncio
import threading

from conftest import fresh_loopback_address
from franka_sim import FrankaSim
from franka_sim.config import ClockMode
from raw_client import RawClient

ANSWERS = 5


def test_answers_on_the_socket_count_while_the_loop_is_blocked():
    host = fresh_loopback_address()

    async def app():
        async with FrankaSim(host=host, clock=ClockMode.lockstep) as sim:
            client = await asyncio.to_thread(RawClient, host)
            assert await asyncio.to_thread(client.move, 2, 4) == 1  # torque, kMotionStarted
            with sim.lock:
                before = (sim.core.cycle.answered_total, sim.core.cycle.lost_total)
            answered = []

            def answer() -> None:  # from the first motion state on, which move() read
                for _ in range(ANSWERS):
                    answered.append(int(client.state["message_id"]))
                    client.send(tau_J_d=[0.0] * 7)
                    client.recv()  # the state this answer released

            thread = threading.Thread(target=answer)
            thread.start()
            thread.join(60)  # blocks the event loop: it reads no datagram meanwhile
            with sim.lock:
                after = (sim.core.cycle.answered_total, sim.core.cycle.lost_total)
            client.close()
            return before, after, answered

    before, after, answered = asyncio.run(app())
    assert answered == list(range(answered[0], answered[0] + ANSWERS))  # one cycle each
    assert after[0] - before[0] == ANSWERS  # every answer counted on time
    assert after[1] - before[1] == 0  # no cycle lost while the loop was blocked
