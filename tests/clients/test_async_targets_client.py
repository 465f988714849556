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


def _until_settled(handler, seconds: float = 20.0):
    deadline, feedback = time.monotonic() + seconds, None
    while time.monotonic() < deadline:
        feedback = handler.get_target_feedback()
        if feedback.status.name in ("kTargetReached", "kAborted"):
            break
        time.sleep(0.01)
    return feedback


def test_a_target_beyond_a_joints_end_is_refused_as_a_position_command_beyond_it():
    with running_sim("--clock", "lockstep", "--enforce-motion-limits") as sim:
        robot = connect(sim.host)
        target = list(robot.read_once().q)
        target[3] = 0.2  # joint 4's upper end is -0.1458 rad
        handler = HANDLER.configure(robot, HANDLER.Configuration([1.0] * 7, 0.01)).handler
        handler.set_joint_position_target(HANDLER.JointPositionTarget(target))
        feedback = _until_settled(handler)
        state = robot.read_once()
    assert feedback.status.name == "kAborted"
    assert "joint_motion_generator_position_limits_violation" in str(state.last_motion_errors)


@pytest.mark.parametrize("joint, end", [(1, -1.7918), (4, 2.8101)])
def test_the_robots_own_generator_keeps_the_velocity_law_up_to_a_joints_end(joint, end):
    """A target on joint 2's lower end, or joint 5's upper one, at up to 2 rad/s: near an end
    the law allows ever less speed, faster than the generator may slow (joint 5), or less than
    it would brake by (joint 2), so it slows early and stops where the law still lets the joint
    move. With the limits enforced on the measured arm, nothing aborts. Then stopControl's
    finish (its q_c all zeros) leaves the arm where it is."""
    with running_sim("--clock", "lockstep", "--enforce-motion-limits") as sim:
        robot = connect(sim.host)
        target = list(robot.read_once().q)
        target[joint] = end
        handler = HANDLER.configure(robot, HANDLER.Configuration([2.0] * 7, 1e-4)).handler
        handler.set_joint_position_target(HANDLER.JointPositionTarget(target))
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:  # until the generator is at rest
            state = robot.read_once()
            if state.robot_mode != pylibfranka.RobotMode.Move or not any(state.dq_d):
                break
            time.sleep(0.01)
        handler.stop_control()
        after = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Move, str(state.last_motion_errors)
    assert 0.003 < abs(end - state.q_d[joint]) < 0.01  # short of the end, by the law's stretch
    assert after.robot_mode == pylibfranka.RobotMode.Idle and not bool(after.last_motion_errors)
    assert after.q_d == state.q_d
