"""The mobile duo through pylibfranka: the base is a robot of its own that a libfranka 0.21
client connects to, reads and drives with a Cartesian-velocity motion; libfranka calls it
mobile (loadModel() refused); the arms on it still serve their own clients while it drives.
Lockstep, so the outcomes do not depend on this machine."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from support.clients import connect
from franka_sim.control import Control
from franka_sim.control.errors import NotFound
from franka_sim.testing import ServerProcess, fresh_loopback_address

HERE = Path(__file__).resolve().parent
BASE_PROGRAM = HERE / "base_program.py"
ARM_PROGRAM = HERE.parent / "support" / "arm_program.py"
JI = pylibfranka.ControllerMode.JointImpedance


@pytest.fixture(scope="module")
def duo():
    base, left, right = (fresh_loopback_address() for _ in range(3))
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                           f"right={right}", "--mobile-base", base,
                           "--clock", "lockstep").wait_ready()
    try:
        yield base, left, right
    finally:
        server.stop()


def program(path: Path, *args) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(path), *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def result(proc: subprocess.Popen) -> dict:
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, out + err
    return json.loads(out.strip().splitlines()[-1])


def test_a_client_connects_reads_the_base_and_libfranka_calls_it_mobile(duo):
    robot = connect(duo[0])
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert len(state.q) == 7 and list(state.q[4:]) == [0.0, 0.0, 0.0]
    with pytest.raises(pylibfranka.InvalidOperationException, match="mobile"):
        robot.load_model()


def test_other_motions_are_refused(duo):
    robot = connect(duo[0])
    for start in (robot.start_joint_position_control, robot.start_joint_velocity_control,
                  robot.start_cartesian_pose_control):
        with pytest.raises(pylibfranka.CommandException, match="not possible"):
            start(JI)
    with pytest.raises(pylibfranka.CommandException, match="not possible"):
        robot.start_torque_control()
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_a_forward_ramp_moves_the_base_as_the_twist_integrates(duo):
    run = result(program(BASE_PROGRAM, duo[0], 0.2, 0.0, 0.0, 1.5))
    assert run["error"] == "" and run["min_rate"] == 1.0 and "Idle" in run["mode"]
    moved = np.subtract(run["after"], run["before"])
    expected = np.subtract(run["integrated"], run["before"])
    assert moved[0] == pytest.approx(0.2, abs=0.01)  # 0.5 s ramps and 0.5 s at 0.2 m/s
    np.testing.assert_allclose(moved, expected, atol=1e-3)
    assert run["steer"] == [0.0, 0.0]  # straight ahead: neither module steered
    assert run["q"][1] == pytest.approx(run["q"][3])  # both wheels rolled alike
    assert abs(run["q"][1]) > 0.1 / 0.08


def test_a_diagonal_twist_steers_both_modules_along_it(duo):
    run = result(program(BASE_PROGRAM, duo[0], 0.1, 0.1, 0.0, 1.2))
    assert run["error"] == ""
    assert run["steer"] == pytest.approx([math.pi / 4, math.pi / 4], abs=1e-6)
    moved = np.subtract(run["after"], run["before"])
    assert moved[0] == pytest.approx(moved[1], abs=1e-6) and moved[0] > 0.05


def test_a_twist_out_of_the_plane_is_refused_with_a_reflex(duo):
    robot = connect(duo[0])
    control = robot.start_cartesian_velocity_control(JI)
    with pytest.raises(pylibfranka.ControlException, match="velocity_limits_violation"):
        for _ in range(100):
            control.readOnce()
            control.writeOnce(pylibfranka.CartesianVelocities([0.0, 0.0, 0.05, 0.0, 0.0, 0.0]))
    del control
    robot.automatic_error_recovery()
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_an_arm_moves_on_its_own_while_the_base_turns_under_it(duo):
    base, left, right = duo
    right_before = Control(right).state()
    base_run = program(BASE_PROGRAM, base, 0.0, 0.0, 0.5, 1.5)
    arm_run = program(ARM_PROGRAM, left, json.dumps([0.3, 0, 0, 0, 0, 0, 0]), 1.0)
    driven, arm = result(base_run), result(arm_run)
    assert driven["error"] == "" and arm["error"] == ""
    assert arm["min_rate"] == 1.0
    np.testing.assert_allclose(arm["q"], arm["target"], atol=2e-3)
    turned = driven["after"][2] - driven["before"][2]
    assert turned == pytest.approx(0.5, abs=0.02)  # 1.0 s of ramps and 0.5 s at 0.5 rad/s
    # The other arm rode along without a tremble: its joints did not move a bit, and its pose
    # in its own base frame only by the round-off of a turned frame.
    right_after = Control(right).state()
    assert right_after["q"] == right_before["q"]
    np.testing.assert_allclose(right_after["O_T_EE"], right_before["O_T_EE"], atol=1e-14)


def test_the_base_control_api_tells_its_pose_and_nothing_else(duo):
    control = Control(duo[0])
    assert control.health()["mobile_base"] is True
    state = control.state()
    assert set(state["pose"]) == {"x", "y", "yaw"} and len(state["q"]) == 4
    with pytest.raises(NotFound):
        control.reset()


def test_a_mobile_base_needs_its_own_address_and_arms_to_carry():
    address = fresh_loopback_address()
    for args in (["--mobile-base", "not-an-address", "--arm", f"a={address}"],
                 ["--mobile-base", address],
                 ["--mobile-base", address, "--arm", f"a={address}"]):
        run = subprocess.run([sys.executable, "-m", "franka_sim", "serve", *args],
                             capture_output=True, text=True, timeout=60)
        assert run.returncode != 0
        assert "mobile" in run.stderr.lower(), run.stderr


def test_faults_on_both_arms_and_the_streaming_base_keep_the_world_running():
    """--inject acts on every robot's path, the base's too: in lockstep the world waits for
    each streaming client's answer through the losses, every motion ends on its target, the
    losses show in each robot's success rate, and the clock runs on afterwards."""
    base, left, right = (fresh_loopback_address() for _ in range(3))
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                           f"right={right}", "--mobile-base", base, "--clock", "lockstep",
                           "--inject", "loss=0.02", "--seed", "3").wait_ready()
    try:
        runs = [program(BASE_PROGRAM, base, 0.2, 0.0, 0.0, 1.5),
                program(ARM_PROGRAM, left, json.dumps([0.3, 0, 0, 0, 0, 0, 0]), 1.5),
                program(ARM_PROGRAM, right, json.dumps([-0.3, 0, 0, 0, 0, 0, 0]), 1.5)]
        drove, *moved = [result(run) for run in runs]
        # (each rate counts the losses; early in a motion its short history makes it coarse)
        assert drove["error"] == "" and drove["min_rate"] < 1.0
        assert np.subtract(drove["after"], drove["before"])[0] == pytest.approx(0.2, abs=0.01)
        for arm in moved:
            assert arm["error"] == "" and arm["min_rate"] < 1.0
            np.testing.assert_allclose(arm["q"], arm["target"], atol=5e-3)
        for host in (base, left, right):
            health = Control(host).health()
            assert health["ready"]
            before = health["cycle"]
            connect(host).read_once()  # a client's read releases a cycle: the clock runs
            assert Control(host).health()["cycle"] > before
        assert not server.log_matching("the cycle failed")
    finally:
        server.stop()
    assert server.proc.returncode == 0
