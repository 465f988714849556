"""Older libfranka through real clients: franky-control 1.0.2 (libfranka 0.15, robot protocol
v9) and franky-panda 0.10.0 (libfranka 0.13, v7) connect, read the state, load their Model
(from the model library the robot sends: kinematics, and for 0.13 the dynamics too; 0.15 takes
its dynamics from the URDF), move in joint and Cartesian space and home and move the Hand; the
Model franky 1.0.2 exposes is the simulator's physics (0.10.0 exposes none: the library's
dynamics are checked against the physics in tests/physics/test_model_library.py); in both
clocks, recorded, and the recording replays identical.

Neither can share an environment with the suite's franky 2.0.0 (one package), so the test
makes a virtual environment for each (pip, from PyPI, once per run) and runs
tests/support/older_franky_program.py there.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.description import hand
from franka_sim.description.kinematics import fk_frames, flange_pose, tip_jacobian
from franka_sim.testing import running_sim
from support.client_venv import client_python

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "older_franky_program.py"
# package: (the robot protocol version its libfranka speaks, whether it loads a Model)
CLIENTS = {"franky-control==1.0.2": (9, True),  # libfranka 0.15.0
           "franky-panda==0.10.0": (7, False)}  # libfranka 0.13


@pytest.fixture(scope="module", params=sorted(CLIENTS))
def client(request, tmp_path_factory) -> tuple[Path, int, bool]:
    """The python of a virtual environment holding the older franky, its version, and
    whether it loads a Model (LoadModelLibrary)."""
    python = client_python(request.param,
                           tmp_path_factory.mktemp(request.param.replace("==", "-")))
    return (python, *CLIENTS[request.param])


def _poses(desc, n: int = 4) -> np.ndarray:
    rng = np.random.default_rng(5)
    return desc.lower + (desc.upper - desc.lower) * rng.uniform(0.1, 0.9, size=(n, 7))


@pytest.fixture(scope="module", params=["lockstep", "realtime"])
def run(request, client, description, tmp_path_factory):
    """The program's run on a fresh simulator of each clock, recorded."""
    python, version, loads_model = client
    recording = tmp_path_factory.mktemp(f"v{version}") / "run.mcap"
    with running_sim("--clock", request.param, "--record", str(recording)) as sim:
        poses = _poses(description)
        done = subprocess.run([str(python), str(PROGRAM), sim.host, json.dumps(poses.tolist())],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        assert sim.log_matching(f"client speaks robot protocol version {version}: served as such")
        assert bool(sim.log_matching("model library sent to the robot client")) == loads_model
    return poses, json.loads(done.stdout.strip().splitlines()[-1]), recording


def test_it_connects_and_reads_the_state(run):
    _, out, _ = run
    assert out["mode"] == "Idle"
    ready = [0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4]
    assert np.allclose(out["q"], ready, atol=1e-6)  # (v10's float32 values, widened)
    assert np.allclose(out["F_T_EE"], hand.F_T_NE_HAND, atol=1e-6)


def test_its_kinematics_are_the_descriptions(run, description):
    """The model library's frames are the physics' own, to round-off."""
    poses, out, _ = run
    if not out["model"]:
        pytest.skip("this franky exposes no Model (tests/physics/test_model_library.py)")
    for q, model in zip(poses, out["model"]):
        F_T_EE = np.asarray(out["F_T_EE"])
        assert np.allclose(model["joint4"], fk_frames(description, q)[3], atol=1e-12)
        assert np.allclose(model["ee"], flange_pose(description, q) @ F_T_EE, atol=1e-12)
        assert np.allclose(model["J_ee"], tip_jacobian(description, q, F_T_EE), atol=1e-12)
        R = flange_pose(description, q)[:3, :3]
        J_flange = tip_jacobian(description, q)
        body = np.vstack([R.T @ J_flange[:3], R.T @ J_flange[3:]])
        assert np.allclose(model["body_J_flange"], body, atol=1e-12)


def test_its_dynamics_are_the_physics(run, physics):
    """From the URDF the robot serves, as for libfranka 0.18 and later."""
    poses, out, _ = run
    if not out["model"]:
        pytest.skip("this franky exposes no Model (tests/physics/test_model_library.py)")
    for q, model in zip(poses, out["model"]):
        g = physics.gravity(q)
        assert np.linalg.norm(np.subtract(model["gravity"], g)) < 1e-6 * np.linalg.norm(g)
        M = physics.mass_matrix(q, include_armature=False)
        assert np.linalg.norm(np.subtract(model["mass"], M)) < 1e-6 * np.linalg.norm(M)


def test_it_moves_the_arm_and_the_hand(run):
    _, out, _ = run
    joint = out["joint"]
    assert np.allclose(joint["q"], joint["target"], atol=2e-3)
    cartesian = out["cartesian"]
    assert np.linalg.norm(cartesian["moved"]) == pytest.approx(0.05, abs=2e-3)
    assert cartesian["mode"] == "Idle"
    gripper = out["gripper"]
    assert gripper["homed"] and gripper["moved"]
    assert gripper["width"] == pytest.approx(0.05, abs=2e-3)


def test_its_recording_replays_identical(run):
    """The robot's own states and the client's bytes are recorded; replay serves the v9
    conversation again from them."""
    *_, recording = run
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(recording)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.startswith("identical"), \
        done.stdout + done.stderr
