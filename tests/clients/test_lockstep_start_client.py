"""pylibfranka in lockstep: a motion's start after the first reads its states as soon as the
client reads them, not START_SPACING apart, and they are the same states.

The server runs in this process (embedded) so the test can make START_SPACING an hour once
the first motion showed how the client starts one: a start that still waited for it would
never end (the client's timeout fails the test), whatever this machine's speed.
"""

from __future__ import annotations

import asyncio
import json
import sys
import textwrap

from franka_sim import FrankaSim
from franka_sim.server import clock, read_probe
from franka_sim.testing import fresh_loopback_address

CLIENT = textwrap.dedent("""
    import json, sys, pylibfranka
    robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)

    def motion():
        control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
        state, _ = control.readOnce()  # a read before the loop, as pylibfranka's examples do
        times, q = [state.time.to_sec()], list(state.q_d)
        for k in range(20):
            state, _ = control.readOnce()
            times.append(state.time.to_sec())
            command = pylibfranka.JointPositions(q)
            command.motion_finished = k == 19
            control.writeOnce(command)
        return [round(1000 * (t - times[0])) for t in times]

    for batch in (1, 2):
        print(json.dumps([motion() for _ in range(batch)]), flush=True)
        sys.stdin.readline()
""")


def test_a_start_after_the_first_goes_at_the_clients_pace_and_reads_the_same_states(
        monkeypatch):
    monkeypatch.setattr(read_probe, "LOOK_BUDGET", 60.0)  # a look is seen however busy the host
    host = fresh_loopback_address()

    async def app() -> list:
        async with FrankaSim(host=host, clock="lockstep") as sim:
            proc = await asyncio.create_subprocess_exec(
                sys.executable, "-c", CLIENT, host, stdin=asyncio.subprocess.PIPE,
                stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)

            async def motions() -> list:
                line = await asyncio.wait_for(proc.stdout.readline(), 120)
                if not line:  # (libfranka gives up on a state that does not come in time)
                    raise AssertionError((await proc.stderr.read()).decode())
                proc.stdin.write(b"\n")
                return json.loads(line)

            first = await motions()
            monkeypatch.setattr(clock, "START_SPACING", 3600.0)
            later = await motions()
            await asyncio.wait_for(proc.wait(), 60)
            learned = sim.core.start_reads
            await sim.reset()  # the robot as freshly started: how a client starts, unknown
            forgotten = sim.core.start_reads is None
        assert learned == 2 and forgotten  # (it read two states after the first: its answer's)
        return first + later

    motions = asyncio.run(app())
    assert len(motions) == 3
    # Each motion: the state read before the loop, then a state each ms from the next one
    # on; the same in the first motion (spaced) and the later ones (at the client's pace).
    assert motions[0] == [0] + list(range(1, 21))
    assert motions[1] == motions[0] and motions[2] == motions[0]
