"""Through pylibfranka, both enforcement switches on, in both clocks: a Cartesian pose motion
whose client withholds one command finishes.

The client filters each pose against the state's O_T_EE_c, as libfranka's own control loop does
by default (a first-order low-pass at 100 Hz): on the cycle after the one it skipped it anchors
on what the robot made of the missed cycle. Its time is the state's, so the skipped cycle moves
the generator on by two.
"""

from __future__ import annotations

import math

import numpy as np
import pylibfranka
import pytest

from support.clients import connect, pose
from franka_sim.testing import running_sim

GAIN = 1e-3 / (1e-3 + 1 / (2 * math.pi * 100.0))
SECONDS = 2.0


def _filtered(T: np.ndarray, T_last: np.ndarray) -> np.ndarray:
    from franka_sim.spatial import exp_rotation, rotation_vector

    out = T.copy()
    out[:3, 3] = GAIN * T[:3, 3] + (1 - GAIN) * T_last[:3, 3]
    out[:3, :3] = exp_rotation(GAIN * rotation_vector(T[:3, :3] @ T_last[:3, :3].T)) @ T_last[:3, :3]
    return out


def _arc(robot, skip: int) -> list[int]:
    """An arc of 0.3 m radius (peak ≈ 0.37 m/s), skipping the answer to the `skip`-th state;
    returns the message_ids of the states answered."""
    control = robot.start_cartesian_pose_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()  # the state that shows the motion started: libfranka leaves it unanswered
    first, _ = control.readOnce()
    T0, t0 = pose(first.O_T_EE_c), round(first.time.to_sec() * 1000)
    state, answered, k = first, [], 0
    while True:
        t = (round(state.time.to_sec() * 1000) - t0) * 1e-3
        angle = math.pi / 4 * 0.5 * (1 - math.cos(2 * math.pi * min(t, SECONDS) / SECONDS))
        T = T0.copy()
        T[0, 3] += 0.3 * math.sin(angle)
        T[2, 3] += 0.3 * (math.cos(angle) - 1)
        if k > 0:
            T = _filtered(T, pose(state.O_T_EE_c))
        command = pylibfranka.CartesianPose(T.ravel(order="F").tolist())
        command.motion_finished = t >= SECONDS
        if k != skip or command.motion_finished:
            control.writeOnce(command)
            answered.append(round(state.time.to_sec() * 1000))
        if command.motion_finished:
            return answered
        state, _ = control.readOnce()
        k += 1


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_a_cartesian_pose_motion_with_one_withheld_command_finishes(clock):
    with running_sim("--enforce-motion-limits", "--enforce-comm-constraints",
                     "--clock", clock) as sim:
        robot = connect(sim.host)
        answered = _arc(robot, skip=500)  # at 0.5 s, at full speed
        assert answered[500] - answered[499] >= 2  # a state went unanswered
        state = robot.read_once()
        assert state.robot_mode == pylibfranka.RobotMode.Idle
        assert not bool(state.last_motion_errors) and not bool(state.current_errors)
        del robot


def _velocity_motion_through_a_long_gap(start, command_at) -> tuple[list[int], object]:
    """A velocity motion of 4.8 s ramped up and down over 0.2 s whose commands are lost for
    4000 cycles from its 300th (a burst on the command path, as a client paused in a debugger
    loses them; its states still come, so no receive of the client's times out). Lockstep and
    a burst: the same cycles every run. Returns the states' message_ids and the state after."""
    from franka_sim.control import Control

    with running_sim("--clock", "lockstep", "--enforce-motion-limits") as sim:
        control = Control(sim.host)
        control.health()  # (its HTTP server loaded before the motion calls it)
        robot = connect(sim.host)
        loop = start(robot)
        loop.readOnce()
        ids = []
        for k in range(4800):
            state, _ = loop.readOnce()
            ids.append(round(state.time.to_sec() * 1000))
            command = command_at(min(k, 200, 4600 - k if k < 4600 else 0) / 200)
            command.motion_finished = k == 4799
            loop.writeOnce(command)
            if k == 300:
                control.set_faults("burst=4000@0.002s,dir=commands")
        return ids, robot.read_once()


def test_a_velocity_motion_goes_on_after_a_long_gap_where_the_arm_was_held():
    """Joint 4 at -0.2 rad/s through the gap: the robot brakes the arm and holds it, and the
    client going on at that speed is judged where the arm was held, not 0.8 rad further, past
    joint 4's lower end."""
    def command_at(share):
        speed = np.zeros(7)
        speed[3] = -0.2 * share
        return pylibfranka.JointVelocities(speed.tolist())

    ids, state = _velocity_motion_through_a_long_gap(
        lambda robot: robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance),
        command_at)
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert ids[-1] - ids[0] > 4700  # (every state read: only commands were lost)


def test_a_cartesian_velocity_motion_goes_on_after_a_long_gap_where_the_arm_was_held():
    """The same gap in a Cartesian velocity motion at 0.05 m/s: when the client is heard again
    the IK starts from rest at the client's speed. That step is the gap's: the joint side of
    the motion is not aborted for it."""
    _, state = _velocity_motion_through_a_long_gap(
        lambda robot: robot.start_cartesian_velocity_control(
            pylibfranka.ControllerMode.JointImpedance),
        lambda share: pylibfranka.CartesianVelocities([0.05 * share, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert not bool(state.last_motion_errors)
