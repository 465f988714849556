"""Every lost motion cycle is recorded with how the robot filled it: a client that withholds
commands finds each withheld cycle in the recording, extrapolated, and braked once too many
were missed in a row; a late command is recorded as not on time. (In lockstep: each withheld
cycle's window runs out, and no other cycle is lost, however busy the machine.)"""

from __future__ import annotations

import numpy as np

from franka_sim.recording.reader import command_of, open_recording
from franka_sim.playback.timeline import lost_cycles
from franka_sim.testing import RawClient, running_sim

JOINT_IMPEDANCE, JOINT_POSITION, MOTION_STARTED = 0, 0, 1
SINGLE, BURST = (100, 200), range(300, 330)  # the client's k: cycles of the motion withheld


def test_withheld_commands_are_recorded_as_lost_and_extrapolated(tmp_path):
    path = tmp_path / "run.mcap"
    withheld: dict[int, int] = {}  # message_id: k
    late = None
    with running_sim("--record", str(path), "--clock", "lockstep") as sim:
        c = RawClient(sim.host)
        try:
            assert c.move(JOINT_IMPEDANCE, JOINT_POSITION) == MOTION_STARTED
            first = int(c.state["message_id"])  # the state the modes flipped on: unanswered
            q0 = np.array(c.state["q_d"], dtype=float)
            for k in range(400):
                state = c.recv()
                n = int(state["message_id"])
                if k in SINGLE or k in BURST:
                    withheld[n] = k
                    continue
                c.send(q_c=q0, motion_generation_finished=k == 399)
                if k == 250:
                    late = n - 1
                    c.send(message_id=late, q_c=q0)  # an answer to a cycle gone
            assert c.reply()[2] == 0  # the Move succeeded
        finally:
            c.close()
    recording = open_recording(path)
    fates = {mark.cycle: mark.label for mark in lost_cycles(recording)}
    assert fates[first] == "held"  # no command yet: the motion holds its start
    assert set(withheld) <= set(fates)
    for n, k in withheld.items():
        if k in SINGLE or k < BURST[0] + 20:
            assert fates[n] == "extrapolated", (k, fates[n])
    assert fates[max(withheld)] == "braked"  # 30 in a row: past the 20 the robot extrapolates
    entries = recording.of("lost_cycle")
    assert all(e.json()["extrapolated"] == (e.json()["filled"] == "extrapolated")
               for e in entries)
    on_time = {command_of(e)[3]["message_id"]: command_of(e)[2] for e in recording.of("command")
               if command_of(e)[3]["message_id"] == late}
    assert on_time == {late: False}
