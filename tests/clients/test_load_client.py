"""SetLoad through pylibfranka: the load round-trips into the state and into the dynamics, and a
really carried object (the grasped cube) reads as external until it is declared."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.description import hand
from franka_sim.testing import running_sim
from support.clients import connect

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import pick_and_place as pp  # noqa: E402

K_THETA = np.array([3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0])
CUBE_MASS = 0.1  # kg (scenes/default.xml)


def _settled(robot, seconds: float = 1.0):
    """The state after `seconds`, read continuously (a state left waiting in the socket's
    buffer would be an old one)."""
    end = time.monotonic() + seconds
    state = robot.read_once()
    while time.monotonic() < end:
        state = robot.read_once()
    return state


def _external_torque_as_libfranka_reads_it(robot, state) -> np.ndarray:
    """tau_J − g(q), with g from libfranka's Model, which includes the declared load."""
    return np.array(state.tau_J) - np.array(robot.load_model().gravity(state))


def test_set_load_round_trips_into_the_state_and_the_dynamics(sim):
    robot = connect(sim.host)
    robot.set_joint_impedance(K_THETA.tolist())
    before = _settled(robot, 0.1)
    inertia = [0.004, 0.0002, 0.0, 0.0002, 0.005, 0.0, 0.0, 0.0, 0.003]
    robot.set_load(1.0, [0.0, 0.0, 0.1], inertia)
    state = _settled(robot)
    assert state.m_load == pytest.approx(1.0)
    np.testing.assert_allclose(state.F_x_Cload, [0.0, 0.0, 0.1], atol=1e-7)
    np.testing.assert_allclose(state.I_load, inertia, atol=1e-9)
    # Nothing is carried: the gravity compensation that now includes 1 kg lifts the arm until
    # the joint springs hold it, K·(q − q_hold) = g_load = −tau_ext ...
    tau_ext = np.array(state.tau_ext_hat_filtered)
    lift = np.array(state.q) - np.array(before.q)
    assert np.abs(tau_ext).max() > 1.0
    np.testing.assert_allclose(K_THETA * lift, -tau_ext, atol=0.02)
    # ... which reads as the environment holding up the missing 1 kg: the robot pushes down.
    np.testing.assert_allclose(state.O_F_ext_hat_K[:3], [0.0, 0.0, -9.81], atol=0.05)
    np.testing.assert_allclose(tau_ext, _external_torque_as_libfranka_reads_it(robot, state),
                               atol=0.02)
    robot.set_load(0.0, [0.0, 0.0, 0.0], [0.0] * 9)
    state = _settled(robot)
    assert state.m_load == 0.0
    np.testing.assert_allclose(state.q, before.q, atol=1e-5)
    assert np.abs(state.tau_ext_hat_filtered).max() < 1e-3


def test_a_grasped_cube_reads_as_external_until_it_is_declared():
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        gripper = pylibfranka.Gripper(sim.host)
        robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
        robot.set_joint_impedance(K_THETA.tolist())
        above, _ = pp.poses_over(pp.CUBE, pp.READY)
        assert pp.pick(robot, gripper, pp.CUBE)  # grasped and lifted, the arm holds `above`
        undeclared = _settled(robot)
        # The robot holds the cube up (+z on it); the arm sags under it by K⁻¹·tau_ext.
        np.testing.assert_allclose(undeclared.O_F_ext_hat_K[:3], [0.0, 0.0, CUBE_MASS * 9.81],
                                   atol=0.03)
        sag = np.array(undeclared.q) - above
        np.testing.assert_allclose(K_THETA * sag, -np.array(undeclared.tau_ext_hat_filtered),
                                   atol=0.01)
        assert np.abs(sag).max() > 2e-5
        # Declared where it hangs (its centre 15 mm under the TCP), it is the robot's own again.
        cube_centre = hand.F_T_NE_HAND[:3, 3] + [0.0, 0.0, pp.GRASP_ABOVE_CENTRE]
        side = pp.CUBE_SIZE
        inertia = np.eye(3) * CUBE_MASS * side**2 / 6
        robot.set_load(CUBE_MASS, cube_centre.tolist(), inertia.ravel().tolist())
        declared = _settled(robot)
        np.testing.assert_allclose(declared.O_F_ext_hat_K, np.zeros(6), atol=0.02)
        np.testing.assert_allclose(declared.tau_ext_hat_filtered, np.zeros(7), atol=0.01)
        np.testing.assert_allclose(declared.q, above, atol=5e-6)
        np.testing.assert_allclose(declared.tau_ext_hat_filtered,
                                   _external_torque_as_libfranka_reads_it(robot, declared),
                                   atol=0.01)
