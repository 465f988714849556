"""The idle RobotState is truthful: every field a client reads agrees with the physics."""

from __future__ import annotations

import socket
import struct

import numpy as np
import pylibfranka
import pytest

from franka_sim.description import hand
from franka_sim.description.kinematics import flange_pose


def _mat(values) -> np.ndarray:
    return np.asarray(values, dtype=float).reshape(4, 4, order="F")


@pytest.fixture
def state(robot):
    return robot.read_once()


def test_O_T_EE_is_flange_forward_kinematics_composed_with_F_T_EE(description, state):
    q = np.array(state.q)
    expected = flange_pose(description, q) @ hand.F_T_NE_HAND
    np.testing.assert_allclose(_mat(state.O_T_EE), expected, atol=2e-6)
    np.testing.assert_allclose(_mat(state.F_T_EE), hand.F_T_NE_HAND, atol=1e-6)
    np.testing.assert_allclose(_mat(state.F_T_NE), hand.F_T_NE_HAND, atol=1e-6)
    np.testing.assert_allclose(_mat(state.NE_T_EE), np.eye(4), atol=0)
    np.testing.assert_allclose(_mat(state.EE_T_K), np.eye(4), atol=0)
    np.testing.assert_allclose(_mat(state.O_T_EE_d), _mat(state.O_T_EE), atol=1e-6)


def test_hand_inertials_and_gravity_are_reported(state):
    assert state.m_ee == pytest.approx(0.73, abs=1e-6)
    np.testing.assert_allclose(state.F_x_Cee, [-0.01, 0.0, 0.03], atol=1e-7)
    np.testing.assert_allclose(
        np.reshape(state.I_ee, (3, 3)), np.diag([0.001, 0.0025, 0.0017]), atol=1e-9
    )
    assert state.m_load == 0.0
    np.testing.assert_allclose(state.O_ddP_O, [0.0, 0.0, -9.81], atol=1e-6)


def test_idle_fields(state):
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert state.control_command_success_rate == 0.0
    assert not bool(state.current_errors) and str(state.current_errors) == "[]"
    assert not bool(state.last_motion_errors)
    np.testing.assert_allclose(state.q_d, state.q, atol=1e-7)
    np.testing.assert_array_equal(state.dq_d, np.zeros(7))
    np.testing.assert_array_equal(state.ddq_d, np.zeros(7))
    np.testing.assert_array_equal(state.tau_J_d, np.zeros(7))
    np.testing.assert_array_equal(state.O_dP_EE_d, np.zeros(6))
    np.testing.assert_array_equal(state.joint_contact, np.zeros(7))
    np.testing.assert_array_equal(state.cartesian_collision, np.zeros(6))
    assert np.max(np.abs(state.dq)) < 1e-6


def test_elbow_is_joint3_and_flip_sign(state):
    q = np.array(state.q)
    assert state.elbow[0] == pytest.approx(q[2], abs=1e-7)
    assert state.elbow[1] == (1.0 if q[3] > -0.467002423653011 else -1.0)


def test_measured_torque_holds_gravity_and_theta_follows_it(robot, state):
    model = robot.load_model()
    gravity = np.array(model.gravity(state))
    np.testing.assert_allclose(state.tau_J, gravity, atol=1e-3 * np.max(np.abs(gravity)))
    assert abs(state.tau_J[3]) > 1.0  # the elbow really carries load: a non-trivial check
    # Elastic joint: theta leads q by tau_J / stiffness.
    np.testing.assert_allclose(
        np.array(state.theta) - np.array(state.q), np.array(state.tau_J) / 7000.0, atol=1e-6
    )


def test_idle_arm_does_not_sag(robot):
    q0 = np.array(robot.read_once().q)
    t0 = robot.read_once().time.to_sec() * 1000
    while robot.read_once().time.to_sec() * 1000 - t0 < 2000:  # 2 s of the robot's own clock
        pass
    q1 = np.array(robot.read_once().q)
    assert np.max(np.abs(q1 - q0)) < 1e-6


def test_message_id_advances_one_per_cycle(sim):
    """Raw UDP client: consecutive states carry consecutive ids (the robot's ms clock)."""
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind((sim.host, 0))
    udp.settimeout(2)
    tcp = socket.create_connection((sim.host, 1337), timeout=2, source_address=(sim.host, 0))
    try:
        tcp.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, udp.getsockname()[1]))
        assert struct.unpack("<IIIBH", tcp.recv(15))[3] == 0
        ids = [struct.unpack_from("<Q", udp.recv(2048))[0] for _ in range(200)]
    finally:
        tcp.close()
        udp.close()
    assert np.all(np.diff(ids) == 1)



def test_the_first_state_after_a_reply_shows_the_request(robot):
    """libfranka's read_once drops what is queued and waits for the next state: that state
    must already show a Set* the client has just had answered, every time (the idle stream
    is packed ahead of its deadline and packed again when a request comes in)."""
    for k in range(40):
        NE_T_EE = np.eye(4)
        NE_T_EE[2, 3] = 0.001 * (k + 1)
        robot.set_EE(NE_T_EE.ravel(order="F").tolist())
        state = robot.read_once()
        assert np.asarray(state.NE_T_EE)[14] == pytest.approx(0.001 * (k + 1), rel=1e-6)  # float32
    load = robot.read_once().m_load
    robot.set_load(0.3, [0.0, 0.0, 0.02], [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3])
    assert load == 0.0 and robot.read_once().m_load == pytest.approx(0.3)
