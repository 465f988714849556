"""Small pylibfranka routines the tests share (what a client program would write)."""

from __future__ import annotations

import math

import numpy as np
import pylibfranka


def connect(host: str) -> pylibfranka.Robot:
    return pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)


def recover(host: str) -> None:
    """automatic_error_recovery() from a short-lived pylibfranka client (after a raw client's reflex)."""
    robot = connect(host)
    robot.automatic_error_recovery()
    del robot


def move_to(robot: pylibfranka.Robot, q_target, seconds: float = 2.0) -> np.ndarray:
    """A smooth joint-position motion to q_target (cosine blend), as examples_common does."""
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0 = np.array(state.q_d)
    q_target = np.asarray(q_target, dtype=float)
    time = 0.0
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        s = 0.5 * (1 - math.cos(math.pi * min(time / seconds, 1.0)))
        command = pylibfranka.JointPositions((q0 + s * (q_target - q0)).tolist())
        if time >= seconds:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    return np.array(robot.read_once().q)


def pose(values) -> np.ndarray:
    """A 4x4 matrix from the 16 column-major numbers libfranka uses."""
    return np.reshape(np.asarray(values, dtype=float), (4, 4), order="F")


def cartesian_pose_motion(robot, targets, controller=pylibfranka.ControllerMode.JointImpedance):
    """Stream a precomputed sequence of 4x4 EE poses, one per cycle; returns the states seen."""
    control = robot.start_cartesian_pose_control(controller)
    control.readOnce()
    seen = []
    for k, T in enumerate(targets):
        state, _ = control.readOnce()
        seen.append(state)
        command = pylibfranka.CartesianPose(np.asarray(T).ravel(order="F").tolist())
        command.motion_finished = k == len(targets) - 1
        control.writeOnce(command)
    return seen
