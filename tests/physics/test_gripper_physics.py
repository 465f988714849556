"""The Hand's fingers in the physics: they move, they touch only the world, and the hand they make
with the palm is — at every opening — exactly the rigid end effector the state reports, so a
client's libfranka Model still equals the simulated dynamics.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description import hand
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics import fingers as fg
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.fingers import FingerCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path

DESC = load_arm_description(default_urdf_text())
READY = np.array(READY_POSE)
K = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
D = np.array([60, 60, 50, 50, 30, 25, 15.0])


def poses(n, seed=5):
    rng = np.random.default_rng(seed)
    return [rng.uniform(DESC.lower, DESC.upper) for _ in range(n)]


def open_to(backend, width, steps=400):
    for _ in range(steps):
        measured = backend.step(JointCommand.impedance(READY, K, D),
                                FingerCommand(width, 0.0, fg.MAX_FINGER_FORCE))
    return measured


def _rel(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b)) / max(np.linalg.norm(b), 1e-12)


@pytest.fixture(scope="module")
def rigid():
    return MujocoBackend(DESC, READY)


def test_composite_is_the_reported_hand_at_every_opening(rigid):
    backend = MujocoBackend(DESC, READY, tool=FINGERS)
    hand_body = backend.model.body("hand").id
    assert backend.model.body_subtreemass[hand_body] == pytest.approx(hand.HAND_MASS, abs=1e-15)
    rng = np.random.default_rng(2)
    for width in (0.08, 0.0, 0.031, 0.081):
        assert open_to(backend, width).tool.width == pytest.approx(width, abs=1e-6)
        for q in poses(4):
            dq = rng.uniform(-1, 1, 7)
            assert _rel(backend.gravity(q), rigid.gravity(q)) < 1e-12
            assert _rel(backend.mass_matrix(q), rigid.mass_matrix(q)) < 1e-12
            assert _rel(backend.coriolis(q, dq), rigid.coriolis(q, dq)) < 1e-12


def test_the_palms_fit_is_the_least_squares_solve_of_its_grid():
    """fingers.GRID_SOLVE, a constant kept so that no server runs an SVD, is pinv of the fit's
    rows on GRID; its bits are those every recording was made with (recordings replay them)."""
    basis = np.array([[1, a, b, a * a, b * b, a * b] for a, b in fg.GRID])
    assert fg.GRID_SOLVE.shape == (6, 9)
    np.testing.assert_allclose(fg.GRID_SOLVE, np.linalg.pinv(basis), rtol=0, atol=1e-14)
    np.testing.assert_allclose(fg.GRID_SOLVE @ basis, np.eye(6), rtol=0, atol=1e-14)


def test_palm_plus_fingers_reproduces_the_composite_exactly():
    palm = fg.Palm(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
    positions, rotations = fg.finger_frames()
    for x1, x2 in [(0.04, 0.04), (0.0, 0.0405), (0.013, 0.002)]:
        com, inertia = palm.inertial(x1, x2)
        parts = [(palm.mass, com, inertia)]
        for k, x in enumerate((x1, x2)):
            R = rotations[k]
            parts.append((fg.FINGER_MASS, positions[k] + R @ (fg.FINGER_COM + [0, x, 0]),
                          R @ fg.FINGER_INERTIA @ R.T))
        total = parts[0]
        for part in parts[1:]:
            total = hand.combine_inertials(*total, *part)
        assert total[0] == pytest.approx(hand.HAND_MASS, abs=1e-15)
        np.testing.assert_allclose(total[1], hand.HAND_COM, atol=1e-15)
        np.testing.assert_allclose(total[2], hand.HAND_INERTIA, atol=1e-15)


def test_libfranka_model_equals_the_fingered_physics(robot):
    """tests/physics/test_model.py's comparison, against the physics the server runs (fingers + scene)."""
    model, state = robot.load_model(), robot.read_once()
    backend = MujocoBackend(DESC, READY, scene_xml=default_scene_path(), tool=FINGERS)
    for width in (0.0, 0.081):
        open_to(backend, width)
        for q in poses(5, seed=9):
            state.q = q.tolist()
            state.dq = [0.0] * 7
            assert _rel(model.gravity(state), backend.gravity(q)) < 1e-6
            M = np.reshape(model.mass(state), (7, 7), order="F")
            assert _rel(M, backend.mass_matrix(q)) < 1e-6


def test_idle_arm_and_fingers_stay_bit_exact_in_the_scene():
    backend = MujocoBackend(DESC, READY, scene_xml=default_scene_path(), tool=FINGERS)
    first = backend.measure()
    for _ in range(2000):
        measured = backend.step(JointCommand.impedance(READY, K, D))
    assert np.array_equal(measured.q, READY) and not measured.dq.any()
    assert measured.tool.width == first.tool.width == fg.OPEN_WIDTH
    np.testing.assert_array_equal(measured.tau_J, first.tau_J)


def test_moving_fingers_leave_the_arm_where_it_is():
    backend = MujocoBackend(DESC, READY, tool=FINGERS)
    for width in (0.0, 0.08, 0.04):
        measured = open_to(backend, width, steps=600)
    assert np.abs(measured.q - READY).max() < 1e-9


def test_fingers_touch_the_world_but_not_the_arm_or_each_other():
    backend = MujocoBackend(DESC, READY, scene_xml=default_scene_path(), tool=FINGERS)
    open_to(backend, 0.0, steps=1000)  # closed: pads face to face, inside the hand's envelope
    model, data = backend.model, backend.data
    touching = {frozenset((model.geom(c.geom1).name, model.geom(c.geom2).name))
                for c in data.contact[:data.ncon]}
    # At most the cube on the table (resting, the cube sleeps and its contact is not listed).
    assert touching <= {frozenset(("scene/top", "scene/cube"))}
    model = backend.model
    finger = model.geom("finger1_collision0")
    for geom in range(model.ngeom):
        other = model.geom(geom)
        touches = bool(finger.contype & other.conaffinity or other.contype & finger.conaffinity)
        is_world = other.name.startswith("scene/") and other.contype[0] == 1
        assert touches == is_world, other.name


def test_a_changed_end_effector_keeps_palm_plus_fingers_exact(rigid):
    load = hand.combine_inertials(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA,
                                  0.8, [0.01, 0.02, 0.09], np.diag([0.002, 0.003, 0.001]))
    fingered = MujocoBackend(DESC, READY, tool=FINGERS)
    heavy_rigid = MujocoBackend(DESC, READY)
    fingered.set_end_effector(*load)
    heavy_rigid.set_end_effector(*load)
    open_to(fingered, 0.02)
    for q in poses(3):
        assert _rel(fingered.gravity(q), heavy_rigid.gravity(q)) < 1e-12
        assert _rel(fingered.mass_matrix(q), heavy_rigid.mass_matrix(q)) < 1e-12


def test_finger_stroke_and_mechanical_stop():
    backend = MujocoBackend(DESC, READY, tool=FINGERS)
    model = backend.model
    for name in fg.FINGER_JOINTS:
        joint = model.joint(name)
        assert joint.type[0] == mujoco.mjtJoint.mjJNT_SLIDE
        np.testing.assert_allclose(joint.range, [0.0, 0.0405])
    pushed = open_to(backend, 0.1, steps=600)  # against the stops with the full force
    assert pushed.tool.width == pytest.approx(0.081, abs=1e-4)
