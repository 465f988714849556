"""Every program in examples/ runs unmodified against a live simulator (lockstep clock)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from franka_sim.testing import running_sim

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _run(name: str, host: str, *args: str) -> str:
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / f"{name}.py"), host, *args],
        capture_output=True, text=True, timeout=240,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


@pytest.fixture(scope="module")
def lockstep_sim():
    with running_sim("--clock", "lockstep") as sim:
        yield sim


def test_echo_robot_state(lockstep_sim):
    out = _run("echo_robot_state", lockstep_sim.host, "3")
    assert out.count("mode=Idle") == 3 and "success_rate=0.0" in out


@pytest.mark.parametrize("name, moved, peak", [
    ("generate_joint_position_motion", (3, 4, 6), math.pi / 4),  # π/8·(1 − cos π) at 2.5 s
    ("generate_joint_velocity_motion", (3, 4, 5, 6), 0.5),  # ∫ ½(1 − cos 2πt) dt over 1 s
])
def test_joint_motions_swing_and_finish(lockstep_sim, name, moved, peak):
    out = _run(name, lockstep_sim.host)
    assert "Finished motion" in out
    excursion = json.loads(re.search(r"Largest excursion per joint = (\[.*\])", out).group(1))
    for joint, e in enumerate(excursion):
        assert e == pytest.approx(peak if joint in moved else 0.0, abs=0.01), joint


def test_joint_impedance_control_tracks(lockstep_sim):
    out = _run("joint_impedance_control", lockstep_sim.host, "3")
    error = float(re.search(r"error ([0-9.]+) rad", out).group(1))
    assert 0.0 < error < 0.05


def test_communication_test_reports_success_rate(lockstep_sim):
    out = _run("communication_test", lockstep_sim.host, "2000")
    rate = float(re.search(r"final_success_rate: ([0-9.]+)", out).group(1))
    assert rate == 1.0  # lockstep: every cycle waits for its answer
    assert "states_missed_by_client: 0" in out


def test_async_position_control_reaches_targets(lockstep_sim):
    out = _run("async_position_control", lockstep_sim.host)
    assert out.count("kTargetReached") == 2
