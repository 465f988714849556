"""SetLoad: the declared load joins the robot's model — its gravity compensation and its
external-force estimate — while the world decides what is really carried (no network here)."""

from __future__ import annotations

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.description import hand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.robot.settings import DEFAULT_K_THETA, Load
from support.harness import Harness, move_request

MASS = 1.5
COM = np.array([0.02, -0.01, 0.12])  # in the flange frame
INERTIA = np.array([[4e-3, 2e-4, 0.0], [2e-4, 5e-3, 0.0], [0.0, 0.0, 3e-3]])


def declared() -> Load:
    return Load(MASS, COM.copy(), INERTIA.copy())


def load_point_jacobian(backend: MujocoBackend, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(load CoM in the base frame, its 3×7 translational Jacobian) at q."""
    O_T_F = backend.flange_pose(q)
    J_F = backend.jacobian_flange(q)
    r = O_T_F[:3, :3] @ COM
    skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    return O_T_F[:3, 3] + r, J_F[:3] - skew @ J_F[3:]


def load_gravity(backend: MujocoBackend, q: np.ndarray) -> np.ndarray:
    """The torque that holds the load up at q: J_Cᵀ·(m·9.81 ẑ)."""
    return load_point_jacobian(backend, q)[1].T @ np.array([0.0, 0.0, MASS * 9.81])


def hang_weight(h: Harness, q: np.ndarray) -> None:
    """The load's weight really hanging on the hand: a force m·g at the load's CoM (xfrc acts at
    the hand's centre of mass, so the lever to the load's CoM adds a torque)."""
    b = h.backend
    body = b.model.body("hand").id
    point, _ = load_point_jacobian(b, q)
    weight = np.array([0.0, 0.0, -MASS * 9.81])
    b.data.xfrc_applied[body, :3] = weight
    b.data.xfrc_applied[body, 3:] = np.cross(point - b.data.xipos[body], weight)


def test_the_state_reports_the_declared_load():
    h = Harness()
    h.core.set_load(declared())
    s = h.cycle()
    assert s["m_load"] == MASS
    np.testing.assert_allclose(s["F_x_Cload"], COM)
    np.testing.assert_allclose(np.reshape(s["I_load"], (3, 3), order="F"), INERTIA)


def test_a_declared_load_that_is_not_there_lifts_the_arm_against_the_joint_impedance():
    h = Harness()
    h.core.set_load(declared())
    s = h.cycle(1500)
    q = np.array(s["q"], dtype=float)
    g_load = load_gravity(h.backend, q)
    # The drives add the load's gravity torque; the joint springs hold it: K·(q − q_hold) = g_L.
    np.testing.assert_allclose(DEFAULT_K_THETA * (q - READY_POSE), g_load, atol=2e-3)
    # The estimate is tau_J minus the model, load included: the missing weight reads as a
    # force the environment lifts with — the robot pushes down on nothing.
    np.testing.assert_allclose(s["tau_ext_hat_filtered"], -g_load, atol=2e-3)
    np.testing.assert_allclose(s["O_F_ext_hat_K"][:3], [0.0, 0.0, -MASS * 9.81], atol=1e-2)
    # Declaring nothing again takes it back out of the model: the arm returns to its hold.
    h.core.set_load(Load())
    s = h.cycle(1500)
    np.testing.assert_allclose(s["q"], READY_POSE, atol=1e-6)
    assert np.abs(s["tau_ext_hat_filtered"]).max() < 1e-3


def test_an_undeclared_load_sags_and_shows_as_external_torque():
    h = Harness()
    for _ in range(1500):
        hang_weight(h, h.backend.measure().q)  # it hangs where the hand is
        s = h.cycle()
    q = np.array(s["q"], dtype=float)
    g_load = load_gravity(h.backend, q)
    np.testing.assert_allclose(DEFAULT_K_THETA * (q - READY_POSE), -g_load, atol=2e-3)
    np.testing.assert_allclose(s["tau_ext_hat_filtered"], g_load, atol=2e-3)
    # The robot holds the weight up: it exerts +m·g on its environment.
    np.testing.assert_allclose(s["O_F_ext_hat_K"][:3], [0.0, 0.0, MASS * 9.81], atol=2e-2)


def test_a_declared_load_that_is_carried_holds_still_and_reads_zero():
    h = Harness()
    hang_weight(h, np.array(READY_POSE))
    h.core.set_load(declared())
    s = h.cycle(1500)
    np.testing.assert_allclose(s["q"], READY_POSE, atol=1e-7)
    np.testing.assert_allclose(s["tau_ext_hat_filtered"], np.zeros(7), atol=1e-4)
    np.testing.assert_allclose(s["O_F_ext_hat_K"], np.zeros(6), atol=1e-4)


def _composite(m1, c1, I1, m2, c2, I2):
    """Mass, CoM and inertia about the CoM of two rigid bodies in one frame."""
    m = m1 + m2
    c = (m1 * c1 + m2 * c2) / m

    def shifted(mass, com, inertia):
        d = com - c
        return inertia + mass * (d @ d * np.eye(3) - np.outer(d, d))

    return m, c, shifted(m1, c1, I1) + shifted(m2, c2, I2)


def test_the_estimate_subtracts_the_declared_loads_inertia_in_motion():
    """Free motion with a declared load that is not there: the estimate is exactly minus the
    load's rigid-body torque (gravity and inertia), as an arm model that carries it computes."""
    h = Harness()
    h.core.set_load(declared())
    h.core.request_move(5, move_request(0, 1))  # joint velocity
    h.cycle()
    # The same arm with the load really welded to the hand, for its inverse dynamics.
    loaded = MujocoBackend(h.backend.desc, np.array(READY_POSE))
    loaded.set_end_effector(*_composite(hand.HAND_MASS, np.asarray(hand.HAND_COM),
                                        np.asarray(hand.HAND_INERTIA), MASS, COM, INERTIA))
    worst, peak = 0.0, 0.0
    for k in range(600):
        dq = 1.2 * np.sin(np.pi * k / 600) * np.array([1.0, -0.6, 0.8, 0.7, -1.0, 1.0, 1.5])
        h.send(dq_c=dq)
        before = h.backend.measure()
        h.cycle()
        after = h.backend.measure()
        expected = np.zeros(7)
        for backend, sign in ((loaded, 1.0), (h.backend, -1.0)):  # the load's share
            q, v = before.q, before.dq
            expected += sign * (backend.mass_matrix(q) @ after.ddq + backend.coriolis(q, v)
                                + backend.gravity(q))
        if k > 5:  # once its velocity history is there
            worst = max(worst, float(np.abs(after.tau_ext + expected).max()))
            peak = max(peak, float(np.abs(expected - load_gravity(h.backend, before.q)).max()))
    assert peak > 0.5  # the motion's inertial share is not negligible ...
    assert worst < 0.02 * peak  # ... and the estimate accounts for it
