"""The command window end to end: an answer that reached the robot before its cycle's window
closed counts, whatever the server's event loop is busy with at that moment. And who reads the
answers: with the realtime clock only the physics thread, at each deadline (the loop is not
woken for every datagram).

The physics thread releases cycles, and reads the socket itself for an answer not yet read:
at a motion cycle's deadline, and in lockstep while it waits for the answer. Here the loop is
blocked on purpose while a raw client answers, so only those reads can see the answers.
Lockstep, so each window is 100 ms of wall time: the client has ample time to answer on a
loaded machine, and the outcome does not depend on timing.
"""

from __future__ import annotations

import asyncio
import threading
import time

from franka_sim import FrankaSim
from franka_sim.config import ClockMode
from franka_sim.testing import RawClient, fresh_loopback_address

ANSWERS = 5


def test_answers_on_the_socket_count_while_the_loop_is_blocked():
    host = fresh_loopback_address()

    async def app():
        async with FrankaSim(host=host, clock=ClockMode.lockstep) as sim:
            client = await asyncio.to_thread(RawClient, host)
            assert await asyncio.to_thread(client.move, 2, 4) == 1  # torque, kMotionStarted
            # From the motion's second state on: nothing waits for an answer to the first
            # (which move() read) beyond a period, so whether one came in time is timing.
            await asyncio.to_thread(client.recv)
            with sim.lock:
                before = (sim.core.window.answered_total, sim.core.window.lost_total)
            answered = []

            def answer() -> None:
                for _ in range(ANSWERS):
                    answered.append(int(client.state["message_id"]))
                    client.send(tau_J_d=[0.0] * 7)
                    client.recv()  # the state this answer released

            thread = threading.Thread(target=answer)
            thread.start()
            thread.join(60)  # blocks the event loop: it reads no datagram meanwhile
            with sim.lock:
                after = (sim.core.window.answered_total, sim.core.window.lost_total)
            client.close()
            return before, after, answered

    before, after, answered = asyncio.run(app())
    assert answered == list(range(answered[0], answered[0] + ANSWERS))  # one cycle each
    assert after[0] - before[0] == ANSWERS  # every answer counted on time
    assert after[1] - before[1] == 0  # no cycle lost while the loop was blocked


def test_realtime_commands_are_read_by_the_physics_thread_only():
    host = fresh_loopback_address()
    sent = 20

    async def app():
        async with FrankaSim(host=host) as sim:  # realtime clock
            readers: list[str] = []
            endpoint = sim.udp
            accept = endpoint.accept

            def spy(data, addr):
                readers.append(threading.current_thread().name)
                return accept(data, addr)

            endpoint.accept = spy
            client = await asyncio.to_thread(RawClient, host)
            assert await asyncio.to_thread(client.move, 2, 4) == 1  # torque, kMotionStarted

            def answer() -> None:  # each answer is read, on time or not
                for _ in range(sent):
                    client.send(tau_J_d=[0.0] * 7)
                    client.recv()
                give_up = time.monotonic() + 10
                while len(readers) < sent + 1 and time.monotonic() < give_up:  # + the finish
                    client.send(tau_J_d=[0.0] * 7, torque_command_finished=True)
                    client.recv()

            await asyncio.to_thread(answer)  # the loop runs meanwhile, free to read
            client.close()
            return readers

    readers = asyncio.run(app())
    assert len(readers) > sent
    assert set(readers) == {"franka-sim-cycle"}
