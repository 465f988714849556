"""libfranka's Model, built from the URDF we serve, equals the simulator's own physics.

The client computes dynamics itself (Pinocchio on the served URDF plus the end-effector
inertials in the state); these tests prove that what it computes is what MuJoCo integrates, so
a controller tuned here meets the same dynamics it will be judged by.
"""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.description.kinematics import flange_pose
from franka_sim.description import hand

N_POSES = 20


def _random_poses(desc, n, seed=7):
    rng = np.random.default_rng(seed)
    lo, hi = desc.lower, desc.upper
    return lo + (hi - lo) * rng.uniform(0.05, 0.95, size=(n, 7))


def _rel(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b)) / max(np.linalg.norm(b), 1e-12)


@pytest.fixture
def model_and_state(robot):
    return robot.load_model(), robot.read_once()


def test_gravity_mass_and_coriolis_match_mujoco(physics, description, model_and_state):
    model, state = model_and_state
    rng = np.random.default_rng(11)
    for q in _random_poses(description, N_POSES):
        dq = rng.uniform(-1.0, 1.0, 7)
        state.q = q.tolist()
        state.dq = dq.tolist()
        g_sim = physics.gravity(q)
        M_sim = physics.mass_matrix(q, include_armature=False)
        c_sim = physics.coriolis(q, dq)
        assert _rel(model.gravity(state), g_sim) < 1e-6
        M_client = np.reshape(model.mass(state), (7, 7), order="F")
        assert _rel(M_client, M_sim) < 1e-6
        assert _rel(model.coriolis(state), c_sim) < 1e-6


def _ee_pose(desc, q):
    return flange_pose(desc, q) @ hand.F_T_NE_HAND


def test_zero_jacobian_matches_finite_differences_of_our_kinematics(description, model_and_state):
    model, state = model_and_state
    desc = description
    h = 1e-6
    for q in _random_poses(desc, 5, seed=3):
        state.q = q.tolist()
        J = np.reshape(model.zero_jacobian(state), (6, 7), order="F")
        J_fd = np.zeros((6, 7))
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = h
            Tp, Tm = _ee_pose(desc, q + dq), _ee_pose(desc, q - dq)
            J_fd[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
            W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ _ee_pose(desc, q)[:3, :3].T
            J_fd[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
        np.testing.assert_allclose(J, J_fd, atol=1e-6)
