"""The Panda (FER) as an arm, through pylibfranka 0.21.3 (robot protocol 10): a Panda served
to a v10 client is a convenience (a real Panda never spoke 10), and its Model, built from the
URDF the robot serves, is the Panda's physics; in one world with an FR3 each arm is its own
kind. --strict-versions refuses the pairings the real robots refuse (the panda-python side:
tests/clients/test_panda_python.py)."""

from __future__ import annotations

import socket
import struct

import numpy as np
import pylibfranka
import pytest

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.testing import fresh_loopback_address, running_sim
from support.clients import connect, move_to

DESCRIPTIONS = {robot: load_arm_description(default_urdf_text(robot)) for robot in ("fr3", "fer")}


def _model_is_the_physics(robot: pylibfranka.Robot, kind: str) -> None:
    description = DESCRIPTIONS[kind]
    physics = MujocoBackend(description, np.array(READY_POSE))
    model, state = robot.load_model(), robot.read_once()
    rng = np.random.default_rng(2)
    for q in description.lower + (description.upper - description.lower) * rng.uniform(
            0.1, 0.9, size=(3, 7)):
        state.q = q.tolist()
        M = np.reshape(model.mass(state), (7, 7), order="F")
        M_sim = physics.mass_matrix(q, include_armature=False)
        assert np.linalg.norm(M - M_sim) < 1e-6 * np.linalg.norm(M_sim)
        g_sim = physics.gravity(q)
        assert np.linalg.norm(np.asarray(model.gravity(state)) - g_sim) < \
            1e-6 * np.linalg.norm(g_sim)


def test_a_v10_client_drives_a_panda_to_a_pose_only_a_panda_reaches():
    with running_sim("--clock", "lockstep", "--robot", "fer") as sim:
        assert Control(sim.host).health()["robot"] == "fer"
        assert Control(sim.host).health()["arm"] == "fer"
        robot = connect(sim.host)
        _model_is_the_physics(robot, "fer")
        target = np.array(READY_POSE)
        target[5] = 0.3  # joint 6: below the FR3's 0.54, inside the Panda's −0.0175
        assert np.allclose(move_to(robot, target), target, atol=2e-3)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot
        assert not sim.log_matching("limits_violation")


def test_one_world_holds_a_panda_and_an_fr3():
    left, right = fresh_loopback_address(), fresh_loopback_address()
    with running_sim("--clock", "lockstep", "--scene", "dual_arm_table",
                     "--arm", f"left:fer={left}", "--arm", f"right={right}") as sim:
        assert sim.log_matching(f"simulated Panda (FER) serving on {left}:1337")
        for host, kind in ((left, "fer"), (right, "fr3")):
            assert Control(host).health()["robot"] == kind
            robot = connect(host)
            _model_is_the_physics(robot, kind)
            del robot


def _connect_version(host: str, version: int) -> tuple[int, int]:
    """A raw Connect of `version`: (status, the version the robot answers with)."""
    with socket.create_connection((host, 1337), timeout=5) as s:
        s.sendall(struct.pack("<IIIHH", 0, 1, 16, version, 4242))
        reply = b""
        while len(reply) < 15 and (chunk := s.recv(64)):
            reply += chunk
    return struct.unpack_from("<BH", reply, 12)


@pytest.mark.parametrize("robot, refused, accepted, own", [
    ("fer", (10, 9, 6), (5,), 5), ("fr3", (5,), (6, 9, 10), 10)])
def test_strict_versions_refuse_what_the_robot_refuses(robot, refused, accepted, own):
    """A Panda speaks protocol 5 (libfranka 0.9), an FR3 6 and later; refused: the robot's
    incompatible-version reply with its own version, and the server keeps serving."""
    with running_sim("--robot", robot, "--strict-versions") as sim:
        for version in refused:
            assert _connect_version(sim.host, version) == (1, own)  # kIncompatibleLibraryVersion
        for version in accepted:
            assert _connect_version(sim.host, version) == (0, version)
        assert sim.log_matching("(--strict-versions): rejected")
        if robot == "fer":
            with pytest.raises(pylibfranka.FrankaException, match="[Ii]ncompatible"):
                connect(sim.host)
        else:
            assert connect(sim.host).read_once().robot_mode == pylibfranka.RobotMode.Idle
