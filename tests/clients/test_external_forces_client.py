"""External forces through pylibfranka: pressing on the table reads the contact force, and a
collision over the thresholds a client lowered aborts the motion with cartesian_reflex."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.testing import running_sim
from support.clients import PAD_BOTTOM, SPOT, connect, move_to, pose

import pick_and_place as pp  # its offline IK

K_X = [1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0]


@pytest.fixture(scope="module")
def sim():
    with running_sim("--clock", "lockstep") as server:
        yield server


@pytest.fixture(scope="module")
def robot(sim):
    robot = connect(sim.host)
    robot.set_cartesian_impedance(K_X)
    return robot


@pytest.fixture
def over_the_table(robot):
    """The TCP 2 cm over the tabletop's touching height, hand pointing down."""
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    move_to(robot, pp.solve_ik([*SPOT, PAD_BOTTOM + 0.02], pp.READY), seconds=1.5)
    yield robot
    if robot.read_once().robot_mode != pylibfranka.RobotMode.Idle:
        robot.automatic_error_recovery()
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    move_to(robot, pp.READY, seconds=1.5)


DOWN, HOLD = 1.0, 1.0  # s: the press goes down, holds, and comes back up


def _press(start: np.ndarray, t: float, depth: float) -> pylibfranka.CartesianPose:
    """The pose command at time t of a press straight down by `depth` from `start`."""
    if t < DOWN:
        s = 0.5 * (1 - math.cos(math.pi * t / DOWN))
    elif t < DOWN + HOLD:
        s = 1.0
    else:
        s = 0.5 * (1 + math.cos(math.pi * min(t - DOWN - HOLD, DOWN) / DOWN))
    target = start.copy()
    target[2, 3] -= depth * s
    command = pylibfranka.CartesianPose(target.ravel(order="F").tolist())
    command.motion_finished = t >= 2 * DOWN + HOLD
    return command


def _aborted(robot, depth: float) -> str:
    """Press down until the robot aborts the motion; the exception's text. (In a function of
    its own, so that no frame keeps the control loop, and with it the connection, alive.)"""
    control = robot.start_cartesian_pose_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    start, t = pose(state.O_T_EE_c), 0.0
    with pytest.raises(pylibfranka.ControlException) as aborted:
        while True:
            _, period = control.readOnce()
            t += period.to_sec()
            control.writeOnce(_press(start, t, depth))
    del control
    return str(aborted.value)


def test_pressing_the_EE_on_the_table_reads_the_contact_force_downwards(over_the_table):
    robot = over_the_table
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [3.0] * 6, [100.0] * 6)
    control = robot.start_cartesian_pose_control(pylibfranka.ControllerMode.CartesianImpedance)
    state, _ = control.readOnce()
    start, t, pressed = pose(state.O_T_EE_c), 0.0, None
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        command = _press(start, t, depth=0.03)
        if pressed is None and t >= DOWN + 0.9 * HOLD:  # settled at the bottom of the press
            pressed = state, pose(command.O_T_EE)
        control.writeOnce(command)
        if command.motion_finished:
            break
    state, target = pressed
    O_F, K_F = np.array(state.O_F_ext_hat_K), np.array(state.K_F_ext_hat_K)
    O_T_EE = pose(state.O_T_EE)
    # The Cartesian spring at K pushes down with K_z·(z_d − z); that is what the table takes.
    spring = K_X[2] * (target[2, 3] - O_T_EE[2, 3])
    assert spring < -5.0
    assert O_F[2] == pytest.approx(spring, rel=0.05)
    assert np.abs(O_F[:2]).max() < 0.05 * abs(spring)
    np.testing.assert_allclose(K_F[:3], O_T_EE[:3, :3].T @ O_F[:3], atol=1e-3 * abs(spring))
    assert K_F[2] > 5.0  # K's z (the hand's approach axis) points down, into the table
    assert state.cartesian_contact[2] == 1.0
    assert not any(state.cartesian_collision) and not any(state.joint_collision)
    # libfranka's own reading of the external torque: tau_J − g(q).
    model = robot.load_model()
    np.testing.assert_allclose(state.tau_ext_hat_filtered,
                               np.array(state.tau_J) - np.array(model.gravity(state)), atol=0.05)
    # Lifted off again: the contact ends and its flag clears.
    robot.read_once()
    after = robot.read_once()
    assert not any(after.cartesian_contact) and abs(after.O_F_ext_hat_K[2]) < 0.5


def test_a_collision_over_lowered_thresholds_aborts_with_cartesian_reflex(over_the_table):
    robot = over_the_table
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [5.0] * 6, [10.0] * 6)
    assert "cartesian_reflex" in _aborted(robot, depth=0.03)
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Reflex
    assert "cartesian_reflex" in str(state.last_motion_errors)
    # Latched until recovery. (The force itself has gone with the impedance that pushed: in
    # lockstep the Move's reply, and so this read, comes once the braked arm is at rest.)
    assert state.cartesian_collision[2] == 1.0
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    robot.automatic_error_recovery()
    robot.read_once()
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle and not bool(state.current_errors)
    assert not any(state.cartesian_collision)  # recovery reset the latch


def test_the_press_on_table_example_prints_the_estimate_next_to_the_spring():
    examples = Path(__file__).resolve().parents[2] / "examples"
    with running_sim("--clock", "lockstep") as server:
        done = subprocess.run([sys.executable, str(examples / "press_on_table.py"), server.host],
                              capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    pressing = [line for line in done.stdout.splitlines() if "t=1.75" in line]
    assert pressing, done.stdout
    spring = float(re.search(r"spring K_z·\(z_d − z\)=\s*([-+0-9.]+) N", pressing[0]).group(1))
    F_z = float(re.search(r"O_F_ext_hat_K=\[[^,]+, [^,]+, ([-+0-9.]+)", pressing[0]).group(1))
    assert spring < -5.0 and F_z == pytest.approx(spring, rel=0.05)
    assert "contact=[0, 0, 1" in pressing[0]
    assert "lifted off: cartesian_contact [0, 0, 0, 0, 0, 0]" in done.stdout


def test_a_collision_over_lowered_joint_thresholds_aborts_with_joint_reflex(over_the_table):
    robot = over_the_table
    robot.set_collision_behavior([1.0] * 7, [2.0] * 7, [100.0] * 6, [100.0] * 6)
    assert "joint_reflex" in _aborted(robot, depth=0.03)
    state = robot.read_once()
    assert "joint_reflex" in str(state.last_motion_errors) and any(state.joint_collision)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    robot.automatic_error_recovery()
    robot.read_once()
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
