"""pylibfranka's AsyncPositionControlHandler at a program's own pace: each target is sent once,
echoing the last state the program read, however long ago; the robot follows it all the same."""

from __future__ import annotations

import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.testing import running_sim
from support.clients import connect

HANDLER = pylibfranka.AsyncPositionControlHandler


@pytest.mark.parametrize("clock", ["realtime", "lockstep"])
def test_targets_set_long_after_the_last_read_are_reached(clock):
    with running_sim("--clock", clock) as sim:
        robot = connect(sim.host)
        q0 = np.array(robot.read_once().q)
        handler = HANDLER.configure(robot, HANDLER.Configuration([1.0] * 7, 0.01)).handler
        for offset, pause in ((0.1, 0.02), (-0.1, 0.2)):
            target = q0.copy()
            target[0] += offset
            handler.get_target_feedback()
            time.sleep(pause)  # the program does something else between reading and setting
            assert handler.set_joint_position_target(
                HANDLER.JointPositionTarget(target.tolist())).was_successful
            deadline, status = time.monotonic() + 20.0, None
            while time.monotonic() < deadline:
                status = handler.get_target_feedback().status
                if status.name == "kTargetReached":
                    break
                time.sleep(0.01)
            assert status.name == "kTargetReached", (offset, status)
        handler.stop_control()
        state = robot.read_once()
    assert abs(state.q[0] - (q0[0] - 0.1)) < 0.01
