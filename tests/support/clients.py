"""Small pylibfranka routines the tests share (what a client program would write)."""

from __future__ import annotations

import math

import numpy as np
import pylibfranka
import pytest

from franka_sim.physics.fingers import TIP_BEYOND_TCP


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


# -- a press on the table (the default scene) until the robot's reflex ------------------------------


PAD_BOTTOM = TIP_BEYOND_TCP  # m under the TCP: where the fingers first touch the table
SPOT = (0.35, 0.2)  # on the table, clear of the cube
SPEED = 0.03  # m/s down
RAMP = 0.05  # s to reach it


def descend_until_reflex(robot) -> list[tuple[float, float, float]]:
    """Down at SPEED until the robot aborts the motion: (time, O_F_ext_hat_K[2],
    cartesian_contact[2]) of every state the motion showed."""
    control = robot.start_cartesian_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    seen, t = [], 0.0
    with pytest.raises(pylibfranka.ControlException, match="cartesian_reflex"):
        while t < 2.0:
            state, period = control.readOnce()
            t += period.to_sec()
            seen.append((t, state.O_F_ext_hat_K[2], state.cartesian_contact[2]))
            v = -SPEED * 0.5 * (1 - math.cos(math.pi * min(t / RAMP, 1.0)))
            control.writeOnce(pylibfranka.CartesianVelocities([0.0, 0.0, v, 0.0, 0.0, 0.0]))
    del control
    return seen


def press_until_reflex(robot, threshold: float):
    """From 5 mm over the touching height, down onto the table with the Cartesian collision
    threshold at `threshold` (contact from 2 N); the states seen, and the force at the reflex."""
    import pick_and_place as pp
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [2.0] * 6, [threshold] * 6)
    move_to(robot, pp.solve_ik([*SPOT, PAD_BOTTOM + 0.005], pp.READY), seconds=1.0)
    seen = descend_until_reflex(robot)
    reflex = robot.read_once()
    assert "cartesian_reflex" in str(reflex.last_motion_errors)
    robot.automatic_error_recovery()
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    move_to(robot, pp.READY, seconds=1.0)
    return seen, reflex.O_F_ext_hat_K[2]
