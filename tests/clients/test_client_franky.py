"""franky-control 2.0.0 against the simulator: libfranka 0.21.2 underneath, Ruckig trajectories on top.

franky and pylibfranka each register pybind11 types of the same name (`Duration`), so the two
cannot be imported into one process, and the rest of this suite imports pylibfranka. Each test
therefore runs one scenario of tests/support/franky_scenarios.py in a child Python, which drives
the robot with franky and prints its observations as one JSON line; the test asserts on them.
The simulator is a `running_sim` subprocess as everywhere else, with the lockstep clock for
every motion, and every assertion is on robot state or robot time.
"""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.testing import running_sim

if importlib.util.find_spec("franky") is None:  # find, never import: see the module docstring
    pytest.skip("franky-control is not installed", allow_module_level=True)

from support.franky_scenarios import READY, RESULT, SINGULAR_POSE  # noqa: E402  (no franky)

SCENARIO_SCRIPT = Path(__file__).parents[1] / "support" / "franky_scenarios.py"


def _run(scenario: str, host: str) -> dict:
    done = subprocess.run([sys.executable, str(SCENARIO_SCRIPT), scenario, host],
                          capture_output=True, text=True, timeout=300)
    lines = [line for line in done.stdout.splitlines() if line.startswith(RESULT)]
    assert done.returncode == 0 and lines, f"franky scenario {scenario} failed:\n{done.stdout}{done.stderr}"
    return json.loads(lines[-1][len(RESULT):])


@pytest.fixture
def lockstep_sim():
    with running_sim("--clock", "lockstep") as sim:
        yield sim


def _translation(matrix) -> np.ndarray:
    return np.asarray(matrix)[:3, 3]


def _rotation_angle(a, b) -> float:
    """Angle between two rotations (from the chord, exact near zero where arccos(trace) is not)."""
    chord = np.linalg.norm(np.asarray(a)[:3, :3] - np.asarray(b)[:3, :3]) / (2 * math.sqrt(2))
    return float(2 * np.arcsin(min(chord, 1.0)))


def test_connect_state_and_model(lockstep_sim):
    out = _run("state", lockstep_sim.host)
    assert np.allclose(out["q"], READY, atol=1e-3)
    assert np.allclose(out["joint_position"], READY, atol=1e-3)
    assert np.allclose(out["q_d"], out["q"], atol=1e-6)
    assert np.abs(out["dq"]).max() < 1e-3
    assert out["robot_mode"] == "Idle"
    assert not out["has_errors"] and out["current_errors"] == "[]"
    assert out["times"][1] > out["times"][0] > 0  # message_id is the robot's ms clock
    T = np.asarray(out["O_T_EE"])
    assert np.allclose(T[3], [0, 0, 0, 1]) and np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-5)
    assert np.allclose(out["ee_translation"], T[:3, 3], atol=1e-6)
    assert out["m_ee"] == pytest.approx(0.73, abs=0.01)  # the Franka Hand
    # libfranka's model (built from the served URDF) agrees with what the robot publishes.
    assert np.allclose(out["model_pose"], T, atol=1e-5)
    assert np.allclose(out["gravity"], out["tau_J"], atol=0.05)
    assert out["jacobian_shape"] == [6, 7]
    assert len(out["urdf_robot_names"]) == 1 and out["urdf_has_link8"]  # served by GetRobotModel


def test_joint_motions_reach_their_targets(lockstep_sim):
    out = _run("joint_motions", lockstep_sim.host)
    jm = out["joint_motion"]
    assert np.allclose(jm["q_end"], jm["target"], atol=3e-3)  # when the motion finished
    assert np.allclose(jm["q"], jm["target"], atol=1e-3)  # and once the arm settled
    assert jm["mode"] == "Idle" and jm["elapsed_ms"] > 100
    assert np.allclose(out["relative"]["q"], out["relative"]["expected"], atol=1e-3)
    assert np.allclose(out["waypoints"]["q"], READY, atol=1e-3) and out["waypoints"]["mode"] == "Idle"
    bl = out["blended"]
    assert np.allclose(bl["q"], bl["target"], atol=1e-3)
    assert bl["mode"] == "Idle" and not bl["has_errors"]


def test_cartesian_motions_move_the_end_effector(lockstep_sim):
    out = _run("cartesian_motions", lockstep_sim.host)
    rel = out["relative"]
    start, end = np.asarray(rel["start"]), np.asarray(rel["end"])
    expected = start[:3, :3] @ np.asarray(rel["offset_ee"])
    assert np.linalg.norm(_translation(end) - _translation(start) - expected) < 3e-3
    assert _rotation_angle(start, end) < 5e-3
    assert rel["mode"] == "Idle"
    ab = out["absolute"]
    assert np.linalg.norm(_translation(ab["end"]) - _translation(ab["goal"])) < 3e-3
    assert _rotation_angle(ab["goal"], ab["end"]) < 5e-3
    wp = out["waypoints"]
    assert np.linalg.norm(_translation(wp["end"]) - _translation(wp["goal"])) < 3e-3
    assert wp["mode"] == "Idle"


def test_velocity_motions(lockstep_sim):
    out = _run("velocity_motions", lockstep_sim.host)
    joint = out["joint"]
    # 0.1 rad/s held for 0.5 s, plus the ramps: 0.05 rad and a bit on joints 1 and 7, opposite signs.
    assert 0.045 < joint["dq_total"][0] < 0.06 and -0.06 < joint["dq_total"][6] < -0.045
    assert np.abs(joint["dq_total"][1:6]).max() < 2e-3
    assert np.abs(joint["dq_end"]).max() < 0.01 and joint["mode"] == "Idle"
    assert joint["elapsed_ms"] >= 500
    cart = out["cartesian"]
    assert 0.022 < cart["dp"][0] < 0.03  # 0.05 m/s for 0.5 s along base x, plus the ramps
    assert abs(cart["dp"][1]) < 2e-3 and abs(cart["dp"][2]) < 2e-3
    assert cart["elapsed_ms"] >= 500 and cart["mode"] == "Idle"


def test_torque_control(lockstep_sim):
    out = _run("torque", lockstep_sim.host)
    zero = out["zero_torque"]
    assert "Move" in zero["modes"]
    assert zero["max_tau_J_d"] < 1e-6
    assert zero["max_deviation"] < 1e-3  # gravity is the robot's business: zero torque holds still
    assert zero["mode_after"] == "Idle" and zero["deviation_after"] < 1e-3
    imp = out["joint_impedance"]
    assert np.allclose(imp["q"], imp["target"], atol=2e-3)
    assert imp["mode_after"] == "Idle"


def test_setters(lockstep_sim):
    out = _run("setters", lockstep_sim.host)
    fr = out["frames"]
    assert _translation(fr["NE_T_EE"])[2] == pytest.approx(0.05, abs=1e-6)
    assert _translation(fr["EE_T_K"])[2] == pytest.approx(0.02, abs=1e-6)
    # F_T_EE = F_T_NE · NE_T_EE: the tool lengthens the flange-to-EE offset by 5 cm...
    assert _translation(fr["F_T_EE"])[2] - _translation(fr["F_T_EE_before"])[2] == pytest.approx(0.05, abs=1e-6)
    # ...and O_T_EE moves with it (the EE points down at the ready pose).
    shift = _translation(fr["O_T_EE"]) - _translation(fr["O_T_EE_before"])
    assert np.allclose(shift, [0.0, 0.0, -0.05], atol=1e-4)
    load = out["load"]
    assert load["m_load"] == pytest.approx(0.5)
    assert np.allclose(load["F_x_Cload"], [0.0, 0.0, 0.05], atol=1e-7)
    assert np.allclose(load["I_load"], [1e-3, 0, 0, 0, 2e-3, 0, 0, 0, 3e-3], atol=1e-9)
    assert load["m_total"] == pytest.approx(load["m_ee"] + 0.5, abs=1e-6)
    assert out["during_motion"] is not None and "command not possible" in out["during_motion"]
    assert np.allclose(out["reset"]["F_T_EE"], fr["F_T_EE_before"], atol=1e-6)
    assert out["reset"]["m_load"] == 0.0


def test_stop_preempts_a_running_motion(lockstep_sim):
    out = _run("stop", lockstep_sim.host)
    assert out["preempted"] is not None and "preempted" in out["preempted"]
    after = out["after"]
    assert after["mode"] == "Idle" and not after["has_errors"]
    assert 0.0 < after["q0"] < 0.3  # stopped part-way
    assert np.allclose(out["moved_again"], READY, atol=2e-3)


def test_cartesian_motion_from_a_singular_pose_is_refused(lockstep_sim):
    out = _run("singular", lockstep_sim.host)
    assert np.allclose(out["at"], SINGULAR_POSE, atol=2e-3)
    assert out["refused"] is not None
    assert out["refused"].startswith("CommandException") and "singular pose" in out["refused"]
    after = out["after"]
    assert after["mode"] == "Idle" and not after["has_errors"]  # refused, not aborted
    assert np.allclose(after["q"], out["at"], atol=1e-4)
    assert np.allclose(out["back"], READY, atol=2e-3)


def test_reflex_then_automatic_error_recovery():
    with running_sim("--clock", "lockstep", "--enforce-motion-limits") as sim:
        out = _run("reflex_recovery", sim.host)
        assert sim.log_matching("controller_torque_discontinuity")
    assert out["aborted"] is not None and "controller_torque_discontinuity" in out["aborted"]
    reflex = out["reflex"]
    assert reflex["mode"] == "Reflex" and reflex["has_errors"]
    assert "controller_torque_discontinuity" in reflex["current_errors"]
    assert "controller_torque_discontinuity" in reflex["last_motion_errors"]
    assert out["move_in_reflex"] is not None and "Reflex" in out["move_in_reflex"]
    assert out["recovered"] is True
    after = out["after"]
    assert after["mode"] == "Idle" and not after["has_errors"] and after["current_errors"] == "[]"
    assert out["moved_again"] == "Idle"


def test_a_reflex_inside_a_burst_reads_as_the_robot_reports_it():
    """In lockstep the world settles after the reflex in one tick; the burst dropped the
    reflex's own state, so the settle's states go until one reaches the client (as the
    robot's next would), and the exception counts the burst's 25, not the settle's hundreds."""
    with running_sim("--clock", "lockstep", "--enforce-comm-constraints",
                     "--inject", "burst=25@3s") as sim:
        out = _run("burst_reflex", sim.host)
    assert "communication_constraints_violation" in out["aborted"]
    assert "control_command_success_rate: 0.75" in out["aborted"]
    assert "packets lost in a row in the last sample: 25" in out["aborted"]


def test_an_elbow_past_joint_3s_end_is_an_elbow_limit_violation():
    """franky plans the elbow smoothly, so only its range is wrong: 3.2 rad against joint 3's
    upper end of 2.9065."""
    with running_sim("--clock", "lockstep", "--enforce-motion-limits") as sim:
        out = _run("elbow_beyond_its_range", sim.host)
        assert sim.log_matching("cartesian_motion_generator_elbow_limit_violation: elbow "
                                "position 2.9")
    assert "cartesian_motion_generator_elbow_limit_violation" in out["aborted"]


def test_a_top_grasp_at_the_cubes_centre_touches_it_with_the_pads_only(lockstep_sim):
    """The palm's underside is where the fingers leave it: with the TCP at the cube's centre
    it stays 2 cm above the top face, nothing pushes back, and the grasp holds."""
    out = _run("centred_top_grasp", lockstep_sim.host)
    assert out["mode"] == "Idle" and abs(out["tcp_z"] - 0.025) < 1e-3
    assert abs(out["force_z"]) < 0.5 and out["grasped"] is True


def test_gripper(lockstep_sim):
    out = _run("gripper", lockstep_sim.host)
    assert out["server_version"] == 3
    assert out["homing"] is True
    assert 0.079 <= out["max_width"] <= 0.083
    assert out["move"] is True and out["width_after_move"] == pytest.approx(0.04, abs=1e-3)
    assert out["grasp_nothing"] is False  # nothing between the fingers: kUnsuccessful
    width, grasped = out["after_grasp"]
    assert not grasped and width < 0.02 - 0.005
    assert out["open"] is True and out["width_open"] == pytest.approx(out["max_width"], abs=1e-3)
    assert out["too_wide"] is not None and "Command failed" in out["too_wide"]
    assert out["stop"] is True
    assert isinstance(out["stopped_move"], str) and "Command aborted" in out["stopped_move"]
    assert out["width_after_stop"] > 0.01 + 0.005  # stopped before its goal
    times = out["state_times"]
    assert times == sorted(times) and len(set(times)) == 3
