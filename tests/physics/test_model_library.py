"""The model library older libfranka loads (model_library/): its frames and Jacobians are the
description's, it is built once per description and kept, and a client of another machine is
answered without one; for each arm it serves (the FR3's and the Panda's descriptions). Needs a
C compiler, as serving it does."""

from __future__ import annotations

import ctypes
import logging
import shutil

import numpy as np
import pytest
from construct import Container

from franka_sim.description.kinematics import fk_frames, flange_pose, tip_jacobian
from franka_sim.model_library import ModelLibrary
from franka_sim.model_library.build import cache_dir, this_machine

if shutil.which("cc") is None and shutil.which("gcc") is None:
    pytest.skip("no C compiler: the model library cannot be built here", allow_module_level=True)

HERE = Container(architecture=this_machine()[0], system=this_machine()[1])
_DOUBLES = ctypes.POINTER(ctypes.c_double)


@pytest.fixture(scope="module", params=["fr3", "fer"])
def description(request):
    """Each packaged arm's (here instead of the suite's FR3 alone)."""
    from franka_sim.description.urdf import default_urdf_text, load_arm_description

    return load_arm_description(default_urdf_text(request.param))


@pytest.fixture(scope="module")
def physics(description):
    from franka_sim.config import READY_POSE
    from franka_sim.physics.mujoco_backend import MujocoBackend

    return MujocoBackend(description, np.array(READY_POSE))


@pytest.fixture(scope="module")
def library(description, tmp_path_factory):
    path = tmp_path_factory.mktemp("model-library") / "model.so"
    path.write_bytes(ModelLibrary(description).for_client(HERE))
    return ctypes.CDLL(str(path))


def _call(function, *arrays, size: int) -> np.ndarray:
    out = np.zeros(size)
    function(*[np.ascontiguousarray(a, dtype=float).ctypes.data_as(_DOUBLES) for a in arrays],
             out.ctypes.data_as(_DOUBLES))
    return out


def test_its_frames_and_jacobians_are_the_descriptions(library, description):
    rng = np.random.default_rng(9)
    F_T_EE = np.eye(4)
    F_T_EE[:3, 3] = [0.01, -0.02, 0.1034]
    for q in description.lower + (description.upper - description.lower) * rng.uniform(
            0.05, 0.95, size=(5, 7)):
        frames = fk_frames(description, q)
        for n in range(1, 8):
            pose = _call(getattr(library, f"O_T_J{n}"), q, size=16).reshape(4, 4).T
            assert np.allclose(pose, frames[n - 1], atol=1e-14)
        assert np.allclose(_call(library.O_T_J8, q, size=16).reshape(4, 4).T,
                           flange_pose(description, q), atol=1e-14)
        ee = _call(library.O_T_J9, q, F_T_EE.T.ravel(), size=16).reshape(4, 4).T
        assert np.allclose(ee, flange_pose(description, q) @ F_T_EE, atol=1e-14)
        J = _call(library.O_J_J9, q, F_T_EE.T.ravel(), size=42).reshape(7, 6).T
        assert np.allclose(J, tip_jacobian(description, q, F_T_EE), atol=1e-14)
        R = ee[:3, :3]
        body = _call(library.Ji_J_J9, q, F_T_EE.T.ravel(), size=42).reshape(7, 6).T
        assert np.allclose(body, np.vstack([R.T @ J[:3], R.T @ J[3:]]), atol=1e-14)


def test_frame_one_needs_no_q(library, description):
    """Joint 1's Jacobians do not depend on q (libfranka calls them without one)."""
    J = np.zeros(42)
    library.O_J_J1(J.ctypes.data_as(_DOUBLES))
    expected = tip_jacobian(description, np.zeros(7), np.linalg.inv(flange_pose(
        description, np.zeros(7))) @ fk_frames(description, np.zeros(7))[0])
    expected[:, 1:] = 0.0
    assert np.allclose(J.reshape(7, 6).T, expected, atol=1e-14)


def test_it_is_built_once_and_kept(description, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    first = ModelLibrary(description).for_client(HERE)
    kept = list(cache_dir().glob("model-library-*.so"))
    assert len(kept) == 1 and kept[0].read_bytes() == first
    monkeypatch.setenv("CC", "/nonexistent/cc")  # a second build would fail: it reads the cache
    assert ModelLibrary(description).for_client(HERE) == first


def test_another_machine_or_no_compiler_is_answered_without_one(description, tmp_path,
                                                                monkeypatch, caplog):
    with caplog.at_level(logging.WARNING):
        other = Container(architecture=HERE.architecture, system="kWindows")
        assert ModelLibrary(description).for_client(other) is None
        assert "/kWindows asked for" in caplog.text
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
        monkeypatch.setattr("franka_sim.model_library.build.system_compiler",
                            lambda: ["/nonexistent/cc"])  # a compiler that cannot run
        assert ModelLibrary(description).for_client(HERE) is None
        assert "did not compile" in caplog.text or "no C compiler" in caplog.text


def test_its_dynamics_are_the_physics(library, description, physics):
    """What libfranka 0.9–0.13 take from it: M, c and g with the end effector's load (here the
    Hand's, as the state gives it), equal to MuJoCo's rigid bodies (rotors left out, as the
    client's Model leaves them out)."""
    from franka_sim.description import hand

    m, c, inertia = hand.HAND_MASS, np.asarray(hand.HAND_COM), np.asarray(hand.HAND_INERTIA)
    library.M_NE.argtypes = [_DOUBLES, _DOUBLES, ctypes.c_double, _DOUBLES, _DOUBLES]
    library.c_NE.argtypes = [_DOUBLES, _DOUBLES, _DOUBLES, ctypes.c_double, _DOUBLES, _DOUBLES]
    library.g_NE.argtypes = [_DOUBLES, _DOUBLES, ctypes.c_double, _DOUBLES, _DOUBLES]
    pointer = lambda a: np.ascontiguousarray(a, dtype=float).ctypes.data_as(_DOUBLES)  # noqa: E731
    rng = np.random.default_rng(4)
    for q in description.lower + (description.upper - description.lower) * rng.uniform(
            0.05, 0.95, size=(5, 7)):
        dq = rng.uniform(-1.0, 1.0, 7)
        g, M, coriolis = np.zeros(7), np.zeros(49), np.zeros(7)
        library.g_NE(pointer(q), pointer([0.0, 0.0, -9.81]), m, pointer(c),
                     g.ctypes.data_as(_DOUBLES))
        library.M_NE(pointer(q), pointer(inertia), m, pointer(c), M.ctypes.data_as(_DOUBLES))
        library.c_NE(pointer(q), pointer(dq), pointer(inertia), m, pointer(c),
                     coriolis.ctypes.data_as(_DOUBLES))
        assert np.allclose(g, physics.gravity(q), atol=1e-12)
        assert np.allclose(M.reshape(7, 7), physics.mass_matrix(q, include_armature=False),
                           atol=1e-12)
        assert np.allclose(coriolis, physics.coriolis(q, dq), atol=1e-12)
