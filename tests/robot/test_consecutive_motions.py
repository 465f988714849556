"""A motion started right after another ends from where the arm is: it has settled on q_d.

The robot's internal joint controller makes the arm follow a motion's q_d closely, so when the
motion ends the arm is on its final q_d and at rest, and a generator that takes its start from
the measured q or O_T_EE (not the commanded q_d or O_T_EE_c) starts from where the robot holds.
Here, both enforcement switches on, with the next Move sent as soon as the last one is answered.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from franka_sim.protocol.enums import MoveControllerMode as Ctrl
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.protocol.enums import MoveStatus, RobotMode
from franka_sim.protocol.errors import ERROR_NAMES
from support.harness import Harness


def _errors(h: Harness) -> list[str]:
    return [name for name, bit in zip(ERROR_NAMES, h.state["errors"]) if bit]


def _joint_motion(h: Harness, start: str, seconds: float, amplitude: float) -> np.ndarray:
    """Joints 1-7 swing by `amplitude` along a cosine blend, from the state's `start` field;
    the last q_c."""
    assert h.move(Ctrl.kJointImpedance, Gen.kJointPosition) == MoveStatus.kMotionStarted
    h.cycle(2)  # the flip state, then the first one libfranka answers
    q0, n = np.array(h.state[start], dtype=float), round(seconds * 1000)
    for k in range(n + 1):
        q = q0 + amplitude * 0.5 * (1 - math.cos(math.pi * k / n))
        h.send(q_c=q, motion_generation_finished=k == n)
        h.cycle()
    return q


def _cartesian_motion(h: Harness, start: str, seconds: float, distance: float) -> None:
    """The EE along x and down z by `distance`, from the state's `start` pose."""
    assert h.move(Ctrl.kJointImpedance, Gen.kCartesianPosition) == MoveStatus.kMotionStarted
    h.cycle(2)
    T0 = np.reshape(np.array(h.state[start], dtype=float), (4, 4), order="F")
    n = round(seconds * 1000)
    for k in range(n + 1):
        T = T0.copy()
        T[[0, 2], 3] += np.array([1.0, -1.0]) * distance * 0.5 * (1 - math.cos(math.pi * k / n))
        h.send(O_T_EE_c=T.ravel(order="F"), motion_generation_finished=k == n)
        h.cycle()


def test_the_arm_ends_a_motion_on_its_q_d_and_at_rest():
    h = Harness()
    q_final = _joint_motion(h, "q_d", 1.0, 0.5)  # peak 0.79 rad/s, 1.2 rad/s² at the ends
    assert h.state["robot_mode"] == RobotMode.kIdle
    assert np.abs(h.state["q"] - q_final).max() < 5e-6  # rad
    assert np.abs(h.state["dq"]).max() < 2e-3  # rad/s


@pytest.mark.parametrize("gap", [0, 20, 50])  # ms the client takes between two motions
@pytest.mark.parametrize("start", ["q", "q_d"])
def test_a_joint_motion_from_the_measured_q_right_after_another_passes(start, gap):
    h = Harness(enforce_motion_limits=True, enforce_comm_constraints=True)
    _joint_motion(h, "q_d", 1.0, 0.5)
    h.cycle(gap)
    _joint_motion(h, start, 1.0, -0.5)
    h.cycle(gap)
    _joint_motion(h, start, 0.5, 0.2)
    assert [status for _, _, status in h.statuses()] == [MoveStatus.kSuccess] * 3
    assert _errors(h) == []


@pytest.mark.parametrize("gap", [0, 20, 50])
@pytest.mark.parametrize("start", ["O_T_EE", "O_T_EE_c"])
def test_a_cartesian_motion_from_the_measured_pose_right_after_another_passes(start, gap):
    h = Harness(enforce_motion_limits=True, enforce_comm_constraints=True)
    _joint_motion(h, "q_d", 1.0, 0.3)
    h.cycle(gap)
    _cartesian_motion(h, start, 1.0, 0.05)
    h.cycle(gap)
    _cartesian_motion(h, start, 1.0, -0.05)
    assert [status for _, _, status in h.statuses()] == [MoveStatus.kSuccess] * 3
    assert _errors(h) == []
