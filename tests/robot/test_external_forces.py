"""External torque, the wrench at K and the contact/collision flags, cycle by cycle (no network).

The physics knows the force the environment exerts on the arm exactly (contacts, pushes); the
robot reports it in its own sign (what the robot exerts on the environment), low-pass filtered,
mapped to K, and judged against the SetCollisionBehavior thresholds. A collision stops a motion.
"""

from __future__ import annotations


import mujoco
import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS, TIP_BEYOND_TCP
from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.protocol.enums import AutomaticErrorRecoveryStatus, Command, MoveStatus, RobotMode
from franka_sim.protocol.errors import error_index
from franka_sim.robot.controllers import impedance_damping
from franka_sim.robot.external_forces import (
    FILTER_CUTOFF_HZ,
    FILTER_GAIN,
    ExternalForces,
    Thresholds,
    accelerating,
    active_thresholds,
)
from franka_sim.robot.settings import CollisionThresholds
from support.harness import Harness, reply_status

import pick_and_place as pp  # its offline IK

ARM = load_arm_description(default_urdf_text())
ROBOT_GEOMS = ("link", "hand", "finger")


def thresholds(lower_torque=100.0, upper_torque=100.0, lower_force=100.0, upper_force=100.0):
    """The same thresholds for both phases, as libfranka's four-array setCollisionBehavior."""
    return CollisionThresholds(
        np.full(7, lower_torque), np.full(7, upper_torque), np.full(7, lower_torque),
        np.full(7, upper_torque), np.full(6, lower_force), np.full(6, upper_force),
        np.full(6, lower_force), np.full(6, upper_force))


def table_harness(**kwargs) -> Harness:
    """The harness on the default scene with the Hand's fingers, as the server runs it."""
    h = Harness(**kwargs)
    h.backend = MujocoBackend(ARM, np.array(READY_POSE), scene_xml=default_scene_path(),
                              tool=FINGERS)
    h.cycle()
    return h


def joint_motion(h: Harness, q_goal, seconds: float = 1.0) -> list:
    """A minimum-jerk joint-position Move to q_goal; returns the Move's replies."""
    assert h.move(0, 0) == MoveStatus.kMotionStarted
    h.cycle()
    q0 = np.array(h.state["q_d"], dtype=float)
    n = int(seconds * 1000)
    for k in range(1, n + 1):
        s = k / n
        h.send(q_c=q0 + (10 * s**3 - 15 * s**4 + 6 * s**5) * (np.asarray(q_goal) - q0),
               motion_generation_finished=k == n)
        h.cycle()
        if h.replies:
            break
    return h.statuses()


def pose(values) -> np.ndarray:
    return np.reshape(np.asarray(values, dtype=float), (4, 4), order="F")


def push_hand(h: Harness, force=(0.0, 0.0, 0.0)) -> None:
    h.backend.data.xfrc_applied[h.backend.model.body("hand").id, :3] = force


def table_contacts(backend: MujocoBackend) -> tuple[np.ndarray, list]:
    """(total force the table exerts on the robot, [(point, force)]), in the base frame."""
    m, d = backend.model, backend.data
    forces = []
    for i, c in enumerate(d.contact[:d.ncon]):
        names = (m.geom(c.geom1).name, m.geom(c.geom2).name)
        if "scene/top" not in names or not any(n.startswith(ROBOT_GEOMS) for n in names):
            continue
        local = np.zeros(6)
        mujoco.mj_contactForce(m, d, i, local)
        on_geom2 = c.frame.reshape(3, 3).T @ local[:3]  # the normal points from geom1 to geom2
        forces.append((c.pos.copy(), on_geom2 if names[0] == "scene/top" else -on_geom2))
    return sum((f for _, f in forces), np.zeros(3)), forces


# -- the estimator on its own ------------------------------------------------------------------
NEVER = Thresholds(*[np.full(k, 1e3) for k in (7, 7, 6, 6)])  # no flag will be set


def test_the_filter_is_a_first_order_low_pass_at_the_documented_cutoff():
    assert FILTER_GAIN == pytest.approx(1 - np.exp(-2 * np.pi * FILTER_CUTOFF_HZ * 1e-3))
    est, step = ExternalForces(), np.arange(1.0, 8.0)
    for n in range(1, 60):
        est.update(step, np.eye(4), None, np.eye(4), NEVER)
        np.testing.assert_allclose(est.tau_ext_hat_filtered, step * (1 - (1 - FILTER_GAIN) ** n))
    # One time constant, 1/(2π·f_c) ≈ 8 ms, brings it to 63 %.
    tau = 1 / (2 * np.pi * FILTER_CUTOFF_HZ)
    assert 1 - (1 - FILTER_GAIN) ** round(tau * 1e3) == pytest.approx(1 - np.exp(-1), abs=0.03)


def test_a_decayed_estimate_is_exactly_zero_again_and_costs_nothing():
    est = ExternalForces()
    est.update(np.full(7, 5.0), np.eye(4), None, np.eye(4), NEVER)
    for _ in range(2000):
        est.update(np.zeros(7), np.eye(4), None, np.eye(4), NEVER)
    assert not est.tau_ext_hat_filtered.any()
    version = est.version
    est.update(np.zeros(7), np.eye(4), None, np.eye(4), NEVER)
    assert est.version == version  # nothing recomputed, nothing for the publisher to rewrite


def test_the_wrench_reads_zero_near_a_singularity(physics):
    stretched = np.zeros(7)  # straight up: joints 1, 3, 5 and 7 in line
    O_T_F, J_F = physics.flange_pose_and_jacobian(stretched)
    assert np.linalg.svd(J_F, compute_uv=False)[-1] < 1e-9
    est = ExternalForces()
    est.update(np.full(7, 3.0), O_T_F, J_F, np.eye(4), NEVER)
    assert est.tau_ext_hat_filtered.any()
    assert not est.O_F_ext_hat_K.any() and not est.K_F_ext_hat_K.any()


def test_acceleration_thresholds_apply_while_the_generator_accelerates():
    c = CollisionThresholds()  # acceleration 20, nominal 10 (setDefaultBehavior's values)
    assert not accelerating(None) and not accelerating(np.zeros(7))
    assert accelerating(np.array([0, 0, 0, 0, 0, 0, 1.0]))
    assert active_thresholds(c, True).upper_force[0] == 20.0
    assert active_thresholds(c, False).upper_torque[0] == 10.0


# -- against the physics ------------------------------------------------------------------------
def test_an_untouched_arm_reads_exactly_zero_and_holds_bit_exact():
    h = table_harness()
    h.cycle(500)
    for field in ("tau_ext_hat_filtered", "O_F_ext_hat_K", "K_F_ext_hat_K", "joint_contact",
                  "cartesian_contact", "joint_collision", "cartesian_collision"):
        assert not np.any(h.state[field]), field
    assert not h.backend.measure().tau_ext.any()
    np.testing.assert_array_equal(h.backend.measure().q, READY_POSE)


def test_a_push_reads_as_the_force_the_robot_exerts_on_the_pusher():
    h = Harness()
    force = np.array([3.0, -4.0, -12.0])  # on the hand's centre of mass, in the base frame
    push_hand(h, force)
    h.cycle(1500)  # the arm yields to its new rest, the filter settles
    s, b = h.state, h.backend
    O_T_EE = pose(s["O_T_EE"])  # K = EE here
    com = b.data.xipos[b.model.body("hand").id]
    np.testing.assert_allclose(s["O_F_ext_hat_K"][:3], -force, atol=1e-3)
    moment = np.cross(com - O_T_EE[:3, 3], -force)  # about K
    np.testing.assert_allclose(s["O_F_ext_hat_K"][3:], moment, atol=1e-3)
    R = O_T_EE[:3, :3]
    np.testing.assert_allclose(s["K_F_ext_hat_K"][:3], R.T @ -force, atol=1e-3)
    # As libfranka's force_control example reads it: tau_J − g(q) is the external torque.
    q = np.array(s["q"], dtype=float)
    np.testing.assert_allclose(s["tau_ext_hat_filtered"], np.array(s["tau_J"]) - b.gravity(q),
                               atol=2e-3)


@pytest.mark.parametrize("above, touches", [(0.002, False), (-0.001, True)])
def test_the_fingertips_reach_where_the_real_ones_do(above, touches):
    """franka_description's fingertips end 9.5 mm beyond the TCP (docs/figures.md, "The Franka
    Hand"): a TCP held 2 mm higher than that over the table leaves them clear of it, 1 mm
    lower puts them on it."""
    assert TIP_BEYOND_TCP == pytest.approx(0.0095, abs=1e-9)
    h = table_harness()
    q = pp.solve_ik([0.35, 0.2, 0.0095 + above], pp.READY)
    assert joint_motion(h, q, 1.5) == [(Command.Move, 5, MoveStatus.kSuccess)]
    h.cycle(300)
    on_robot, _ = table_contacts(h.backend)
    assert (on_robot[2] > 0.5) == touches


def test_pressing_on_the_table_reads_the_contact_force_downwards():
    h = table_harness()
    h.core.settings.collision = thresholds(lower_force=5.0)
    # The fingertips commanded 2 mm into the top: the contact yields ~0.7 mm, the impedance the rest.
    q = pp.solve_ik([0.35, 0.2, TIP_BEYOND_TCP - 0.002], pp.READY)
    assert joint_motion(h, q, 1.5) == [(Command.Move, 5, MoveStatus.kSuccess)]
    h.cycle(300)
    s = h.state
    on_robot, contacts = table_contacts(h.backend)
    assert on_robot[2] > 10.0  # the table pushes the fingers up ...
    np.testing.assert_allclose(s["O_F_ext_hat_K"][:3], -on_robot, atol=0.1)  # ... the robot down
    assert s["O_F_ext_hat_K"][2] < -10.0
    p_K = pose(s["O_T_EE"])[:3, 3]
    moment = sum(np.cross(p - p_K, -f) for p, f in contacts)
    np.testing.assert_allclose(s["O_F_ext_hat_K"][3:], moment, atol=0.02)
    np.testing.assert_array_equal(s["cartesian_contact"], np.abs(s["K_F_ext_hat_K"]) > 5.0)
    assert s["cartesian_contact"][2] == 1.0 and not s["cartesian_collision"].any()


def test_contact_flags_clear_when_the_contact_ends():
    h = Harness()
    h.core.settings.collision = thresholds(lower_torque=2.0, lower_force=5.0)
    push_hand(h, [0.0, 0.0, -15.0])
    h.cycle(300)
    assert h.state["cartesian_contact"][2] == 1.0 and h.state["joint_contact"].any()
    assert not h.state["cartesian_collision"].any() and not h.state["joint_collision"].any()
    push_hand(h)
    h.cycle(300)
    assert not h.state["cartesian_contact"].any() and not h.state["joint_contact"].any()


def test_an_idle_collision_latches_its_flag_until_recovery_without_a_reflex():
    h = Harness()
    h.core.settings.collision = thresholds(lower_force=5.0, upper_force=20.0)
    push_hand(h, [0.0, 0.0, -30.0])
    h.cycle(300)
    push_hand(h)
    h.cycle(300)
    s = h.state
    assert s["cartesian_collision"][2] == 1.0 and not s["cartesian_contact"].any()
    assert s["robot_mode"] == RobotMode.kIdle and not s["errors"].any()
    (reply,) = h.core.request_recovery(7)
    assert reply_status(reply) == (Command.AutomaticErrorRecovery, 7,
                                   AutomaticErrorRecoveryStatus.kSuccess)
    assert not h.cycle()["cartesian_collision"].any()


@pytest.mark.parametrize("reflex, limits", [
    ("cartesian_reflex", dict(lower_force=10.0, upper_force=10.0)),
    ("joint_reflex", dict(lower_torque=3.0, upper_torque=3.0)),
])
def test_a_collision_during_a_motion_is_a_reflex(reflex, limits):
    h = Harness()
    h.core.settings.collision = thresholds(**limits)
    assert h.move(0, 0) == MoveStatus.kMotionStarted
    h.cycle()
    q = np.array(h.state["q_d"], dtype=float)
    for k in range(400):
        push_hand(h, [0.0, 0.0, -0.05 * k])  # a hand pressing harder and harder
        h.send(q_c=q)
        h.cycle()
        if h.replies:
            break
    assert h.statuses() == [(Command.Move, 5, MoveStatus.kReflexAborted)]
    s = h.state
    assert s["robot_mode"] == RobotMode.kReflex
    assert s["errors"][error_index(reflex)] and s["reflex_reason"][error_index(reflex)]
    field = "cartesian_collision" if reflex == "cartesian_reflex" else "joint_collision"
    assert s[field].any()
    # Moves are refused until recovery, which clears the errors and the latched flags.
    assert h.move(0, 0) == MoveStatus.kCommandNotPossibleRejected
    push_hand(h)
    assert h.core.request_recovery(8) == []
    for _ in range(1000):
        h.cycle()
        if h.replies:
            break
    recovered = (Command.AutomaticErrorRecovery, 8, AutomaticErrorRecoveryStatus.kSuccess)
    assert h.statuses() == [recovered]
    s = h.cycle()
    assert s["robot_mode"] == RobotMode.kIdle and not s["errors"].any() and not s[field].any()


def test_hitting_the_table_with_thresholds_lowered_aborts_the_motion():
    h = table_harness()
    h.core.settings.collision = thresholds(lower_force=5.0, upper_force=15.0)
    q = pp.solve_ik([0.35, 0.2, TIP_BEYOND_TCP - 0.005], pp.READY)  # 5 mm into the table
    assert joint_motion(h, q, 1.5) == [(Command.Move, 5, MoveStatus.kReflexAborted)]
    s = h.state
    assert s["reflex_reason"][error_index("cartesian_reflex")]
    assert s["cartesian_collision"][2] == 1.0 and s["O_F_ext_hat_K"][2] < -15.0


def test_the_arms_own_joint_limits_are_not_external():
    b = MujocoBackend(ARM, np.array(READY_POSE))
    K = np.full(7, 200.0)
    q_d = np.array(READY_POSE)
    q_d[0] = ARM.upper[0] + 0.2  # joint 1 pressed against its stop
    command = JointCommand.impedance(q_d, K, impedance_damping(K))
    for _ in range(1500):
        measured = b.step(command)
    assert b.data.qfrc_constraint[0] < -5.0  # the stop pushes back ...
    assert not measured.tau_ext.any()  # ... and that is the robot's own business
