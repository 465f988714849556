"""The two-arm examples run end to end against one world of two arms (dual_arm_table, lockstep),
and the control API's ground truth shows each arm where the program put it.

Each example runs as its own subprocess (it starts one client process per arm itself); the
simulator is one `franka-sim serve --arm left=A --arm right=B` subprocess.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CUBE_SIZE = 0.05


@contextmanager
def two_arms(*flags: str):
    """(left, right) Control clients of a fresh lockstep dual_arm_table world."""
    left, right = fresh_loopback_address(), fresh_loopback_address()
    server = ServerProcess(left, "--arm", f"left={left}", "--arm", f"right={right}",
                           "--scene", "dual_arm_table", "--clock", "lockstep", *flags).wait_ready()
    try:
        assert server.wait_for_log(f"serving on {right}:"), "\n".join(server.lines)
        yield Control(left), Control(right)
    finally:
        server.stop()


def _run(name: str, *hosts: str) -> str:
    done = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), *hosts],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def _position(control: Control, body: str) -> np.ndarray:
    return np.array(control.pose(body)["position"])


def _tcp(control: Control, arm: str) -> np.ndarray:
    """The arm's TCP in the world frame (O_T_EE is in its base frame; the bases are not turned)."""
    O_T_EE = np.array(control.state()["O_T_EE"])
    return O_T_EE[:3, 3] + _position(control, f"{arm}/link0")


def test_handover_example_puts_the_cube_in_the_right_hand():
    with two_arms() as (left, right):
        out = _run("bimanual_handover", left.host, right.host)
        assert "right: holding the cube: width 0.0500 m, is_grasped True" in out

        cube = _position(right, "scene/cube")
        f1, f2 = _position(right, "right/finger1"), _position(right, "right/finger2")
        across = f2 - f1  # the pads' inner faces, one finger to the other
        between = np.dot(cube - f1, across) / np.dot(across, across)
        assert 0.3 < between < 0.7  # on the line between the fingers, not beside one
        assert np.linalg.norm(cube - _tcp(right, "right")) < 0.025  # in the pads' grip
        assert cube[2] > 0.2  # lifted well off the table (its top is z = 0)
        state = right.state()
        assert state["gripper_width"] == pytest.approx(CUBE_SIZE, abs=0.002)
        assert state["robot_mode"] == "Idle" and state["errors"] == []

        assert left.state()["gripper_width"] == pytest.approx(0.08, abs=0.002)  # let go
        assert np.linalg.norm(cube - _tcp(left, "left")) > 0.1  # and gone


@pytest.mark.skipif(importlib.util.find_spec("franky") is None,
                    reason="franky-control is not installed")
def test_franky_example_moves_each_object_out_and_each_arm_above_it():
    # As the robot would hold it: every limit enforced (the example's dynamics factor is one
    # whose Cartesian motions the arm's joints can follow).
    with two_arms("--enforce-motion-limits", "--enforce-comm-constraints") as (left, right):
        out = _run("bimanual_franky", left.host, right.host)
        assert "left: set the cube down at x = 0.55 m" in out
        assert "right: set the box down at x = 0.55 m" in out

        for control, arm, body, y in ((left, "left", "scene/cube", 0.15),
                                      (right, "right", "scene/box", -0.15)):
            position = _position(control, body)
            # Where the program set it: the cube or the box on its table spot, 10 cm further out
            # (the mirrored fingers keep a held object centred between them).
            assert position[:2] == pytest.approx([0.55, y], abs=0.002), body
            tcp = _tcp(control, arm)
            assert tcp[:2] == pytest.approx([0.55, y], abs=0.002), arm  # right above it, mirrored
            assert tcp[2] > position[2] + 0.1  # and clear of it
            state = control.state()
            assert state["gripper_width"] == pytest.approx(0.08, abs=0.002)  # let go
            assert state["robot_mode"] == "Idle" and state["errors"] == []
