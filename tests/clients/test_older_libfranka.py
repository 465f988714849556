"""An older libfranka through a real client: franky-control 1.0.2 (libfranka 0.15, robot
protocol v9) connects, reads the state, loads its Model (kinematics from the model library the
robot sends, dynamics from the URDF), moves in joint and Cartesian space and homes and moves the
Hand, and its Model is the simulator's physics; in both clocks, recorded, and the recording
replays identical.

franky 1.0.2 cannot share an environment with the suite's franky 2.0.0 (one package name), so
the test makes a virtual environment of its own for it (pip, from PyPI, once per run) and runs
tests/support/franky_0_15_program.py there.
"""

from __future__ import annotations

import json
import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest

from franka_sim.description import hand
from franka_sim.description.kinematics import fk_frames, flange_pose, tip_jacobian
from franka_sim.testing import running_sim

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "franky_0_15_program.py"
FRANKY = "franky-control==1.0.2"  # libfranka 0.15.0 inside: robot protocol v9


@pytest.fixture(scope="module")
def franky_0_15(tmp_path_factory) -> Path:
    """The python of a virtual environment holding franky-control 1.0.2."""
    where = tmp_path_factory.mktemp("franky-0.15")
    venv.EnvBuilder(with_pip=True).create(where)
    python = where / "bin" / "python"
    done = subprocess.run([str(python), "-m", "pip", "install", "--quiet", FRANKY],
                          capture_output=True, text=True, timeout=600)
    if done.returncode != 0:  # no package registry within reach: nothing to test with
        pytest.skip(f"pip could not install {FRANKY}: {done.stderr.strip()[-300:]}")
    return python


def _poses(desc, n: int = 4) -> np.ndarray:
    rng = np.random.default_rng(5)
    return desc.lower + (desc.upper - desc.lower) * rng.uniform(0.1, 0.9, size=(n, 7))


@pytest.fixture(scope="module", params=["lockstep", "realtime"])
def run(request, franky_0_15, description, tmp_path_factory):
    """The program's run on a fresh simulator of each clock, recorded."""
    recording = tmp_path_factory.mktemp("v9") / "run.mcap"
    with running_sim("--clock", request.param, "--record", str(recording)) as sim:
        poses = _poses(description)
        done = subprocess.run([str(franky_0_15), str(PROGRAM), sim.host,
                               json.dumps(poses.tolist())],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        assert sim.log_matching("client speaks robot protocol version 9: served as such")
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
