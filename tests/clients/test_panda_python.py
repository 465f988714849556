"""The Panda's most common client, unmodified: panda-python 1.1.1 from PyPI (its bundled
libfranka 0.9.2 speaks robot protocol v5; tests/support/panda_py_program.py). It connects,
reads the state, loads its Model from the model library the robot sends (kinematics and
dynamics equal to the physics), moves to the start pose, to a joint position and to a pose,
runs a torque controller of panda_py.controllers for 5 s, and homes the Hand, moves it and
grasps and lifts the cube; in both clocks, recorded, and the recording replays identical. And
on the Panda itself (`--robot fer`): its Model is the Panda's physics, and it moves to a pose
only a Panda reaches (joint 6 at 0.3 rad).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.description import hand
from franka_sim.description.kinematics import fk_frames, flange_pose, tip_jacobian
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.testing import running_sim
from support.client_venv import client_python

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import pick_and_place as pp  # noqa: E402

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "panda_py_program.py"
READY = np.array(READY_POSE)


@pytest.fixture(scope="module")
def python(tmp_path_factory) -> Path:
    return client_python("panda-python==1.1.1", tmp_path_factory.mktemp("panda-python"))


def _plan(description) -> dict:
    rng = np.random.default_rng(7)
    poses = description.lower + (description.upper - description.lower) * rng.uniform(
        0.1, 0.9, size=(4, 7))
    above, at = pp.poses_over(pp.CUBE, pp.READY)
    # On the Panda, joint 6 to 0.3 rad: below the FR3's range (0.54), inside the Panda's.
    step = [0, 0, 0, 0, 0, 0.3 - READY[5], 0] if description.name == "fer" else \
        [0.2, 0, 0, 0, 0, 0, 0]
    return {"poses": poses.tolist(), "target": (READY + step).tolist(),
            "held": (READY + [0, 0, 0, 0, 0, 0, 0.2]).tolist(),
            "above": list(above), "at": list(at)}


@pytest.fixture(scope="module", params=[("lockstep", "fr3"), ("realtime", "fr3"),
                                        ("lockstep", "fer")], ids="-".join)
def arm(request):
    """(clock, robot) of a run and the robot's description."""
    clock, robot = request.param
    return clock, robot, load_arm_description(default_urdf_text(robot))


@pytest.fixture(scope="module")
def run(arm, python, tmp_path_factory):
    """The program's run on a fresh simulator of each clock and arm, recorded; and where the
    cube is once it ends."""
    clock, robot, description = arm
    recording = tmp_path_factory.mktemp("v5") / "run.mcap"
    plan = _plan(description)
    with running_sim("--clock", clock, "--robot", robot, "--record", str(recording)) as sim:
        done = subprocess.run([str(python), str(PROGRAM), sim.host, json.dumps(plan)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        assert sim.log_matching("client speaks robot protocol version 5: served as such")
        assert sim.log_matching("model library sent to the robot client")
        cube = Control(sim.host).pose("cube")["position"]
    return plan, json.loads(done.stdout.strip().splitlines()[-1]), cube, recording


def test_it_connects_and_reads_the_state(run):
    _, out, *_ = run
    assert out["mode"] == "kIdle"
    assert np.allclose(out["q"], READY, atol=1e-6)
    assert np.allclose(out["F_T_EE"], hand.F_T_NE_HAND, atol=1e-6)


def test_its_model_is_the_physics(run, arm):
    """The whole Model comes from the library in libfranka 0.9: kinematics and dynamics, the
    served arm's (the FR3's or the Panda's)."""
    plan, out, *_ = run
    description = arm[2]
    physics = MujocoBackend(description, READY)
    F_T_EE = np.asarray(out["F_T_EE"])
    for q, model in zip(plan["poses"], out["model"]):
        assert np.allclose(model["joint4"], fk_frames(description, q)[3], atol=1e-12)
        assert np.allclose(model["ee"], flange_pose(description, q) @ F_T_EE, atol=1e-12)
        assert np.allclose(model["J_ee"], tip_jacobian(description, q, F_T_EE), atol=1e-12)
        g = physics.gravity(np.asarray(q))
        assert np.linalg.norm(np.subtract(model["gravity"], g)) < 1e-6 * np.linalg.norm(g)
        M = physics.mass_matrix(np.asarray(q), include_armature=False)
        assert np.linalg.norm(np.subtract(model["mass"], M)) < 1e-6 * np.linalg.norm(M)


def test_it_moves_to_the_start_to_a_joint_position_and_to_a_pose(run):
    plan, out, *_ = run
    assert out["start"]["done"] and np.allclose(out["start"]["q"], READY, atol=1e-3)
    assert out["joint"]["done"]
    assert np.allclose(out["joint"]["q"], plan["target"], atol=1e-2)  # its success threshold
    assert out["pose"]["done"]
    goal, reached = np.asarray(out["pose"]["goal"]), np.asarray(out["pose"]["reached"])
    assert np.linalg.norm(reached[:3, 3] - goal[:3, 3]) < 0.02  # its impedance settles short
    assert reached[2, 3] > goal[2, 3] - 0.05 + 0.04  # it did go up


def test_a_torque_controller_holds_its_target_for_5_s(run):
    """panda_py.controllers.JointPosition: an impedance law computed by the client, sent as
    torques (v5's torque Move: zero joint velocities beside tau_J_d)."""
    plan, out, *_ = run
    assert out["torque"]["ran"] >= 5.0
    assert np.allclose(out["torque"]["q"], plan["held"], atol=1e-3)


def test_the_hand_homes_moves_and_grasps_the_cube(run):
    _, out, cube, _ = run
    gripper = out["gripper"]
    assert gripper["homed"] and gripper["moved"]
    assert gripper["width"] == pytest.approx(0.07, abs=1e-3)
    assert gripper["grasped"] and gripper["is_grasped"]
    assert gripper["held_width"] == pytest.approx(pp.CUBE_SIZE, abs=2e-3)
    assert cube[2] > pp.CUBE[2] + 0.1  # lifted with the Hand


def test_its_recording_replays_identical(run):
    """The client's v5 bytes are recorded as sent; replay serves the conversation again."""
    *_, recording = run
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(recording)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.startswith("identical"), \
        done.stdout + done.stderr
