"""The MuJoCo backend: it is the URDF's rigid-body model (plus rotor inertia and the Hand), it
holds still when the robot holds, and its sensors read what a resting FR3's would.

Reference quantities are computed independently of MuJoCo and of our kinematics module: a
modified-DH chain (docs/figures.md, "Kinematics (modified DH)") carrying the description's
inertials, with gravity from the complex-step derivative of the potential energy and the mass
matrix from link Jacobians.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.description import hand
from franka_sim.description.kinematics import flange_pose, frame_pose
from franka_sim.description.urdf import (ACCELEROMETER_BOTTOM, ACCELEROMETER_TOP,
                                         default_urdf_text, load_arm_description)
from franka_sim.physics.arm_model import ROTOR_INERTIA_FR3, collision_bits
from franka_sim.physics.backend import JointCommand, Payload
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.readings import JOINT_STIFFNESS
from franka_sim.physics.scene import build_model

PI = math.pi
DESC = load_arm_description(default_urdf_text())
HOME = np.array([0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4])
K_IDLE = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
D_IDLE = np.array([60, 60, 50, 50, 30, 25, 15.0])
DH = [(0, 0.333, 0), (0, 0, -PI / 2), (0, 0.316, PI / 2), (0.0825, 0, PI / 2),
      (-0.0825, 0.384, -PI / 2), (0, 0, PI / 2), (0.088, 0, PI / 2), (0, 0.107, 0)]


def dh_frames(q):
    """Link 1..7 frames and the flange; complex-safe so it can be complex-step differentiated."""
    frames, T = [], np.eye(4, dtype=complex)
    for (a, d, alpha), qi in zip(DH, list(q) + [0.0]):
        ca, sa, ct, st = math.cos(alpha), math.sin(alpha), np.cos(qi), np.sin(qi)
        T = T @ np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa],
                          [st * sa, ct * sa, ca, d * ca], [0, 0, 0, 1]])
        frames.append(T)
    return frames


def bodies(ee=(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)):
    """(frame index into dh_frames, mass, CoM, inertia about CoM in frame axes) per moving body."""
    out = [(i, DESC.inertials[f"link{i + 1}"].mass, DESC.inertials[f"link{i + 1}"].com,
            DESC.inertials[f"link{i + 1}"].inertia_in_link) for i in range(7)]
    return out + [(7, ee[0], np.asarray(ee[1]), np.asarray(ee[2]))]


def reference_gravity(q, ee=None):
    """g = ∂V/∂q with V = Σ m·9.81·z_com, by complex step (exact to rounding)."""
    parts = bodies() if ee is None else bodies(ee)

    def potential(qc):
        frames = dh_frames(qc)
        return sum(m * 9.81 * (frames[i] @ np.append(c, 1.0))[2] for i, m, c, _ in parts)

    h = 1e-30
    return np.array([potential(q + 1j * h * np.eye(7)[k]).imag / h for k in range(7)])


def reference_mass_matrix(q):
    """M = Σ m·Jvᵀ·Jv + Jwᵀ·I·Jw over the links and the Hand, from geometric Jacobians."""
    frames = [f.real for f in dh_frames(q)]
    M = np.zeros((7, 7))
    for i, m, c, inertia in bodies():
        R, p = frames[i][:3, :3], frames[i][:3, :3] @ c + frames[i][:3, 3]
        Jv, Jw = np.zeros((3, 7)), np.zeros((3, 7))
        for j in range(min(i + 1, 7)):
            z, o = frames[j][:3, 2], frames[j][:3, 3]
            Jv[:, j], Jw[:, j] = np.cross(z, p - o), z
        M += m * Jv.T @ Jv + Jw.T @ (R @ inertia @ R.T) @ Jw
    return M


@pytest.fixture
def backend():
    return MujocoBackend(DESC, HOME)


def poses(n, seed=7):
    rng = np.random.default_rng(seed)
    return [rng.uniform(DESC.lower, DESC.upper) for _ in range(n)]


def hold(backend, q, steps):
    cmd = JointCommand.impedance(q, K_IDLE, D_IDLE)
    for _ in range(steps):
        measured = backend.step(cmd)
    return measured


# -- the model is the description ---------------------------------------------------------------
def test_flange_and_sensor_frames_match_numpy_fk(backend):
    for q in poses(20):
        assert np.allclose(backend.flange_pose(q), flange_pose(DESC, q), atol=1e-9)
    model, data = backend.model, backend._scratch
    for name in ACCELEROMETER_TOP + ACCELEROMETER_BOTTOM:
        site = model.site(name).id
        assert np.allclose(data.site_xpos[site], frame_pose(DESC, q, name)[:3, 3], atol=1e-9)
        assert np.allclose(data.site_xmat[site].reshape(3, 3), frame_pose(DESC, q, name)[:3, :3],
                           atol=1e-9)


def test_inertials_are_kept_exactly(backend):
    model = backend.model
    for i in range(1, 8):
        body, inertial = model.body(f"link{i}"), DESC.inertials[f"link{i}"]
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, body.iquat)
        R = R.reshape(3, 3)
        assert body.mass[0] == inertial.mass
        assert np.allclose(body.ipos, inertial.com, atol=1e-15)
        assert np.allclose(R @ np.diag(body.inertia) @ R.T, inertial.inertia_in_link, atol=1e-15)
    assert model.body("hand").mass[0] == hand.HAND_MASS
    assert model.opt.timestep == 0.001
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert np.allclose(model.dof_armature, ROTOR_INERTIA_FR3)
    assert not model.dof_damping.any() and not model.dof_frictionloss.any()


def test_gravity_matches_potential_energy(backend):
    for q in [HOME] + poses(10):
        reference = reference_gravity(q)
        assert np.allclose(backend.gravity(q), reference, rtol=0, atol=1e-6 * np.abs(reference).max())


def test_mass_matrix(backend):
    for q in [HOME] + poses(5):
        M = backend.mass_matrix(q)
        assert np.allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0
        assert np.allclose(M, reference_mass_matrix(q), atol=1e-9)
        difference = backend.mass_matrix(q, include_armature=True) - M
        assert np.allclose(difference, np.diag(ROTOR_INERTIA_FR3), atol=1e-12)


def test_coriolis(backend):
    q, dq = poses(1)[0], np.array([0.3, -0.5, 0.8, 0.4, -1.0, 1.2, 2.0])
    assert np.allclose(backend.coriolis(q, np.zeros(7)), 0, atol=1e-12)
    assert np.allclose(backend.coriolis(q, 2 * dq), 4 * backend.coriolis(q, dq), atol=1e-10)
    # Passivity: dqᵀ·C·dq = ½·dqᵀ·Ṁ·dq, with Ṁ by central difference along dq.
    h = 1e-6
    M_dot = (backend.mass_matrix(q + h * dq) - backend.mass_matrix(q - h * dq)) / (2 * h)
    assert dq @ backend.coriolis(q, dq) == pytest.approx(0.5 * dq @ M_dot @ dq, rel=1e-6)


def test_flange_jacobian_matches_fk_differences(backend):
    q, h = poses(1, seed=3)[0], 1e-6
    J = backend.jacobian_flange(q)
    for k in range(7):
        plus, minus = flange_pose(DESC, q + h * np.eye(7)[k]), flange_pose(DESC, q - h * np.eye(7)[k])
        assert np.allclose(J[:3, k], (plus[:3, 3] - minus[:3, 3]) / (2 * h), atol=1e-8)
        W = (plus[:3, :3] - minus[:3, :3]) / (2 * h) @ flange_pose(DESC, q)[:3, :3].T
        assert np.allclose(J[3:, k], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-8)


def test_combined_flange_query_agrees(backend):
    for q in poses(3, seed=11):
        pose, jacobian = backend.flange_pose_and_jacobian(q)
        assert np.allclose(pose, flange_pose(DESC, q), atol=1e-12)
        assert np.allclose(jacobian, backend.jacobian_flange(q), atol=1e-12)


# -- behaviour over steps -------------------------------------------------------------------------
def test_idle_hold_is_still(backend):
    measured = hold(backend, HOME, 2000)
    assert np.abs(measured.q - HOME).max() < 1e-9
    assert backend.data.time == pytest.approx(2.0)  # exactly one 1 ms step per call


def test_rest_sensors(backend):
    for measured in (backend.measure(), hold(backend, HOME, 50)):
        gravity = backend.gravity(HOME)
        assert np.allclose(measured.tau_J, gravity, atol=1e-9)
        assert np.allclose(measured.dtau_J, 0, atol=1e-6)
        assert np.allclose(measured.theta, measured.q + measured.tau_J / JOINT_STIFFNESS)
        assert np.allclose(measured.O_T_F, flange_pose(DESC, HOME), atol=1e-12)
        for readings in (measured.accelerometer_top, measured.accelerometer_bottom):
            assert readings.shape == (6, 3)
            assert np.allclose(np.linalg.norm(readings, axis=1), 9.81, atol=1e-6)
        # Joint 1's top sensor sits upside down on the base: specific force points along −z.
        assert np.allclose(measured.accelerometer_top[0], [0, 0, -9.81], atol=1e-9)


def test_torque_on_joint7_accelerates_it(backend):
    tau = np.array([0, 0, 0, 0, 0, 0, 1.0])
    first = backend.step(JointCommand.torque(tau))
    inertia7 = backend.mass_matrix(HOME, include_armature=True)
    expected = np.linalg.solve(inertia7, tau)  # from rest: no coriolis, gravity compensated
    assert np.allclose(first.ddq, expected, rtol=1e-6, atol=1e-9)
    assert first.dq[6] > 0 and first.ddq[6] > 10
    assert np.allclose(first.tau_J - backend.gravity(HOME), tau - ROTOR_INERTIA_FR3 * first.ddq,
                       atol=1e-9)
    second = backend.step(JointCommand.torque(tau))
    assert second.q[6] > first.q[6] > HOME[6]
    assert np.allclose(second.dtau_J, (second.tau_J - first.tau_J) / 0.001)


def test_queries_do_not_disturb_the_simulation():
    a, b = MujocoBackend(DESC, HOME), MujocoBackend(DESC, HOME)
    cmd = JointCommand.torque([0.5, -0.3, 0.2, 0.1, -0.2, 0.3, 0.1])
    for _ in range(20):
        ma = a.step(cmd)
        b.gravity(poses(1)[0]), b.mass_matrix(HOME), b.jacobian_flange(HOME)
        mb = b.step(cmd)
    assert np.array_equal(ma.q, mb.q) and np.array_equal(ma.tau_J, mb.tau_J)


def test_reset(backend):
    hold(backend, HOME, 10)
    backend.step(JointCommand.torque(np.ones(7)))
    q0 = poses(1)[0]
    backend.reset(q0)
    measured = backend.measure()
    assert np.array_equal(measured.q, q0) and not measured.dq.any()
    assert np.allclose(measured.tau_J, backend.gravity(q0)) and not measured.dtau_J.any()


def test_end_effector_change_keeps_gravity_consistent(backend):
    load = hand.combine_inertials(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA,
                                  1.5, [0.02, -0.01, 0.08], np.diag([0.004, 0.005, 0.002]))
    backend.set_end_effector(*load)
    reference = reference_gravity(HOME, ee=load)
    assert np.allclose(backend.gravity(HOME), reference, atol=1e-6 * np.abs(reference).max())
    measured = hold(backend, HOME, 2000)
    assert np.abs(measured.q - HOME).max() < 1e-9
    assert np.allclose(measured.tau_J, reference, atol=1e-6)
    backend.set_end_effector(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
    assert np.allclose(backend.gravity(HOME), reference_gravity(HOME), atol=1e-9)


# -- contacts and scenes --------------------------------------------------------------------------
def test_collision_filtering():
    contype3, affinity3 = collision_bits("link3")
    for other, touches in (("link2", False), ("link4", False), ("link5", True), ("link0", True)):
        contype, affinity = collision_bits(other)
        assert bool(contype3 & affinity or contype & affinity3) is touches, other
    assert collision_bits("hand")[1] & 1  # everything touches the environment
    model = build_model(DESC)
    data = mujoco.MjData(model)
    data.qpos[:7] = HOME
    mujoco.mj_forward(model, data)
    assert data.ncon == 0


def test_scene_is_attached_around_the_arm():
    scene = """<mujoco><worldbody><geom name="floor" type="plane" size="2 2 0.1"/>
      <body name="box" pos="0.5 0 0.03"><freejoint/><geom type="box" size=".03 .03 .03"/></body>
    </worldbody></mujoco>"""
    backend = MujocoBackend(DESC, HOME, scene_xml=scene)
    assert backend.model.body("scene/box").id > 0 and backend.model.opt.timestep == 0.001
    measured = hold(backend, HOME, 500)
    assert np.abs(measured.q - HOME).max() < 1e-9
    box = backend.model.body("scene/box")
    box_z = backend.data.qpos[backend.model.jnt_qposadr[box.jntadr[0]] + 2]
    assert box_z == pytest.approx(0.03, abs=1e-3)  # the box rests on the floor


def test_libfranka_joint_impedance_example_gains_are_stable(backend):
    """Torque control with the example's gains, one cycle late as a real client is, converges.

    Without rotor inertia this diverges within milliseconds on joint 7 (docs: Physics notes).
    """
    K = np.array([600, 600, 600, 600, 250, 150, 50.0])
    D = np.array([50, 50, 50, 20, 20, 20, 10.0])
    target, measured = HOME + 0.05, backend.measure()
    for _ in range(3000):
        tau = K * (target - measured.q) - D * measured.dq + backend.coriolis(measured.q, measured.dq)
        measured = backend.step(JointCommand.torque(tau))
    assert np.abs(measured.q - target).max() < 1e-6


def test_joint_stops_at_the_datasheet_limit(backend):
    tau = np.array([0, 0, 0, 0, 0, 0, 2.0])
    for _ in range(1500):
        measured = backend.step(JointCommand.torque(tau))
    upper = DESC.joints[6].limits.soft_upper
    assert upper - 0.01 < measured.q[6] < upper + 0.01
    assert abs(measured.dq[6]) < 1e-3


def test_description_without_accelerometers_reads_zero():
    import re

    text = re.sub(r'<link name="link\d_accelerometer_\w+"/>\s*<joint name="link\d_accelerometer'
                  r'_\w+_joint" type="fixed">.*?</joint>', "", default_urdf_text(), flags=re.S)
    desc = load_arm_description(text)
    assert not any("accelerometer" in name for name in desc.frames)
    measured = hold(MujocoBackend(desc, HOME), HOME, 10)
    assert not measured.accelerometer_top.any() and measured.accelerometer_bottom.shape == (6, 3)
    assert np.abs(measured.q - HOME).max() < 1e-9


def _measured_fields(m):
    return [m.q, m.dq, m.ddq, m.tau_J, m.dtau_J, m.theta, m.dtheta, m.O_T_F,
            m.accelerometer_top, m.accelerometer_bottom, m.tau_ext, m.J_F,
            np.array([m.tool.width, m.tool.speed, m.tool.force])]


def test_a_step_at_rest_is_skipped_and_bit_identical_to_stepping():
    """Rest (mujoco_backend § Rest): an arm and scene at rest are not recomputed, yet every
    reading, the data and the clock are bit-identical to a backend that steps every cycle,
    through a push (data written from outside), a new command and a finger move."""
    from franka_sim.physics.fingers import FingerCommand
    from franka_sim.physics.scene import default_scene_path

    lazy = MujocoBackend(DESC, HOME, scene_xml=default_scene_path(), tool=FINGERS)
    eager = MujocoBackend(DESC, HOME, scene_xml=default_scene_path(), tool=FINGERS)
    eager._same_inputs = lambda cmd, fingers: False  # never skips
    K = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
    hold = JointCommand.impedance(HOME, K, 0.02 * K, hold=True)
    moved = HOME + 0.01
    away = JointCommand.impedance(moved, K, 0.02 * K, hold=True)  # held at a new pose
    hand_body = lazy.model.body("hand").id
    phases = [(hold, None, 0.0, 400), (hold, None, 5.0, 30), (hold, None, 0.0, 1600),
              (away, None, 0.0, 1600), (away, FingerCommand(0.04, 0.0, 20.0), 0.0, 1600)]
    reused = 0
    previous = None
    for cmd, fingers, push, steps in phases:
        for k in range(steps):
            for b in (lazy, eager):
                b.data.xfrc_applied[hand_body, 2] = push
            f = fingers if k == 0 else None
            a, b = lazy.step(cmd, f), eager.step(cmd, f)
            for x, y in zip(_measured_fields(a), _measured_fields(b)):
                np.testing.assert_array_equal(x, y)
            reused += a is previous
            previous = a
    assert lazy.data.time == eager.data.time
    for name in ("qpos", "qvel", "qacc_warmstart", "qfrc_applied", "sensordata"):
        np.testing.assert_array_equal(getattr(lazy.data, name), getattr(eager.data, name))
    assert reused > 2000  # and the rest was really skipped, in every phase that settles


def test_finishing_a_step_after_its_readings_changes_no_bit():
    """A server finishes each step once the state has left (finish_step); a caller that never
    does gets it done at the start of the next step; and g(q), prepared there, is what the
    step would compute at its start. All three give the same readings and data, through torque
    and impedance motions, a push, the Hand moving, a new end effector and a hold that settles
    (the standstill puts q exactly on the hold, so g(q) moves with it)."""
    from franka_sim.physics.fingers import FingerCommand
    from franka_sim.physics.scene import default_scene_path

    class GravityAtStart(MujocoBackend):
        def finish_step(self):
            super().finish_step()
            self._prepared_for = object()  # so g(q) is computed at the start of every step

    scene = default_scene_path()
    server = MujocoBackend(DESC, HOME, scene_xml=scene, tool=FINGERS)
    plain = MujocoBackend(DESC, HOME, scene_xml=scene, tool=FINGERS)
    at_start = GravityAtStart(DESC, HOME, scene_xml=scene, tool=FINGERS)
    backends = (server, plain, at_start)
    hand_body = server.model.body("hand").id
    rng = np.random.default_rng(3)
    load = Payload(0.8, np.array([0.0, 0.02, 0.06]), np.diag([1e-3, 1e-3, 5e-4]))
    for k in range(3000):
        if k < 300:
            cmd = JointCommand.torque(rng.normal(0.0, 2.0, 7))
            if k >= 150:  # a declared load (SetLoad): its gravity is the robot's model too
                cmd = dataclasses.replace(cmd, load=load)
        else:
            q_d = HOME + 0.05 * math.sin(min(k, 600) * 1e-2)
            cmd = JointCommand.impedance(q_d, K_IDLE, D_IDLE, hold=k >= 600)
        fingers = FingerCommand(0.02, 0.1, 20.0) if k == 100 else None
        if k == 450:
            for b in backends:
                b.set_end_effector(1.2, [0.0, 0.0, 0.05], np.diag([3e-3, 3e-3, 2e-3]))
        for b in backends:
            b.data.xfrc_applied[hand_body, 0] = 8.0 if 200 <= k < 220 else 0.0
        a, b, c = (backend.step(cmd, fingers) for backend in backends)
        server.finish_step()
        server.gravity(HOME + 0.3)  # a query between two cycles (the scratch data moves)
        at_start.finish_step()
        for x, y, z in zip(_measured_fields(a), _measured_fields(b), _measured_fields(c)):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
    assert np.array_equal(a.q, cmd.q_d)  # the hold did settle (the standstill put q there)
    plain.finish_step()
    for name in ("qpos", "qvel", "qacc_warmstart", "qLD", "qfrc_bias", "xpos", "sensordata"):
        np.testing.assert_array_equal(getattr(server.data, name), getattr(plain.data, name))


def test_a_new_end_effector_is_compensated_from_the_next_step(backend):
    """Gravity compensation is prepared while the state is out (finish_step); a change of
    what hangs on the flange after that must not leave the next step with the old one."""
    at_rest = hold(backend, HOME, 50).q.copy()
    backend.finish_step()
    backend.set_end_effector(2.5, [0.0, 0.0, 0.08], np.diag([5e-3, 5e-3, 3e-3]))
    measured = hold(backend, at_rest, 1)
    np.testing.assert_array_equal(measured.q, at_rest)
