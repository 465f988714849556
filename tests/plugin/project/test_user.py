"""A user's test module: the franka_sim fixture, no conftest. Run by tests/plugin/test_plugin.py
in a throw-away directory; each test records (name, worker, host) in $FRANKA_SIM_RECORD."""

import base64
import http.client
import json
import math
import os
import socket
import ssl

import numpy as np
import pylibfranka
import pytest

from franka_sim.config import READY_POSE

JI = pylibfranka.ControllerMode.JointImpedance
_HELD = []  # what a careless test leaves behind


def connect(host):
    return pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)


def record(franka_sim, name):
    worker = os.environ.get("PYTEST_XDIST_WORKER", "-")
    with open(os.environ["FRANKA_SIM_RECORD"], "a") as out:
        out.write(f"{name} {worker} {franka_sim.host}\n")


def test_reads_a_state(franka_sim):
    record(franka_sim, "default")
    robot = connect(franka_sim.host)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
    assert franka_sim.control.state()["robot_mode"] == "Idle"
    assert franka_sim.control.health()["clock"] == os.environ["FRANKA_SIM_EXPECTED_CLOCK"]
    assert any("FCI client" in line and "connected" in line for line in franka_sim.log)


@pytest.mark.parametrize("joint", range(3))
def test_starts_from_the_same_world_then_moves_the_arm(franka_sim, joint):
    record(franka_sim, "default")
    robot = connect(franka_sim.host)
    assert np.allclose(robot.read_once().q, READY_POSE, atol=1e-3)
    control = robot.start_joint_position_control(JI)
    q0 = np.array(control.readOnce()[0].q_d)
    t = 0.0
    while t < 0.3:
        state, period = control.readOnce()
        t += period.to_sec()
        q = q0.copy()
        q[joint] += 0.15 * 0.5 * (1 - math.cos(math.pi * min(t / 0.3, 1.0)))
        command = pylibfranka.JointPositions(q.tolist())
        command.motion_finished = t >= 0.3
        control.writeOnce(command)
    del control
    assert abs(franka_sim.control.state()["q"][joint] - READY_POSE[joint]) > 0.1


def test_leaves_a_motion_running(franka_sim):
    record(franka_sim, "default")
    robot = connect(franka_sim.host)
    control = robot.start_joint_velocity_control(JI)
    control.readOnce()
    _HELD.append((robot, control))  # still connected, mid-motion, when the next test starts
    assert franka_sim.control.state()["robot_mode"] == "Move"


def test_after_a_motion_left_running_the_world_is_back(franka_sim):
    record(franka_sim, "default")
    robot = connect(franka_sim.host)
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert np.allclose(state.q, READY_POSE, atol=1e-3)


def test_leaves_a_hand_client_connected(franka_sim):
    record(franka_sim, "default")
    gripper = pylibfranka.Gripper(franka_sim.host)
    _HELD.append(gripper)  # its connection still open when the next test starts
    assert franka_sim.control.health()["tool_client_connected"]


def test_after_a_hand_client_was_left_the_hand_serves_this_one(franka_sim):
    record(franka_sim, "default")
    gripper = pylibfranka.Gripper(franka_sim.host)  # (refused were the last one still there)
    assert gripper.homing()


@pytest.mark.franka_sim(faults="loss=0.05,dir=commands")
def test_a_marker_injects_network_faults(franka_sim):
    record(franka_sim, "marked-faults")
    robot = connect(franka_sim.host)
    control = robot.start_joint_position_control(JI)
    state, _ = control.readOnce()
    for k in range(300):  # hold still for 0.3 s
        command = pylibfranka.JointPositions(list(state.q_d))
        command.motion_finished = k == 299
        control.writeOnce(command)
        state, _ = control.readOnce() if k < 299 else (state, None)
    del control
    assert robot.read_once().control_command_success_rate < 1.0
    faults = franka_sim.control.faults()
    assert faults["spec"] == "loss=0.05,dir=commands" and faults["commands"]["dropped"] > 0


@pytest.mark.franka_sim(faults={"loss": 2.0})
def test_a_marker_with_faults_not_valid_is_an_error(franka_sim):
    pass


@pytest.mark.franka_sim(faults="loss=0.3,dir=commands")
class TestFaultsOfAClass:
    def test_its_tests_have_them(self, franka_sim):
        record(franka_sim, "marked-faults")
        assert franka_sim.control.faults()["spec"] == "loss=0.3,dir=commands"

    @pytest.mark.franka_sim(faults=None)
    def test_a_test_may_have_none(self, franka_sim):
        record(franka_sim, "marked-faults")
        assert franka_sim.control.faults()["spec"] is None and franka_sim.faults is None


def test_leaves_network_faults_injected(franka_sim):
    record(franka_sim, "faults")
    report = franka_sim.control.faults()  # (a marker's ended with its test, counts and all)
    assert report["spec"] is None and report["commands"]["dropped"] == 0
    franka_sim.control.set_faults("loss=0.3,dir=commands", seed=3)
    assert franka_sim.control.faults()["spec"] == "loss=0.3,dir=commands"


def test_after_faults_were_left_none_are_injected(franka_sim):
    record(franka_sim, "faults")  # (serially, on the server the test before left them on)
    assert franka_sim.control.faults()["spec"] is None


@pytest.mark.parametrize("k", range(2))
@pytest.mark.franka_sim(gripper=False, scene="dual_arm_table")  # (a packaged scene's name)
def test_without_a_hand_port_1338_refuses(franka_sim, k):
    record(franka_sim, "no-gripper")
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection((franka_sim.host, 1338), timeout=2)
    assert franka_sim.control.state()["robot_mode"] == "Idle"
    assert "scene/box" in {body["name"] for body in franka_sim.control.bodies()}


@pytest.mark.franka_sim(enforce_motion_limits=True)
def test_a_step_aborts_under_enforced_motion_limits(franka_sim):
    record(franka_sim, "limits")
    robot = connect(franka_sim.host)
    control = robot.start_joint_position_control(JI)
    first = np.array(control.readOnce()[0].q_d)
    with pytest.raises(pylibfranka.ControlException, match="velocity_discontinuity"):
        for k in range(100):
            control.readOnce()
            q = first.copy()
            q[3] += 0.05 if k > 5 else 0.0
            control.writeOnce(pylibfranka.JointPositions(q.tolist()))
    assert "joint_motion_generator_velocity_discontinuity" in franka_sim.control.state()["errors"]


@pytest.mark.franka_sim(desk_boot="locked")
def test_a_robot_booted_locked_moves_only_once_brought_up(franka_sim):
    record(franka_sim, "locked")
    with pytest.raises(pylibfranka.NetworkException, match="Connection to FCI refused"):
        connect(franka_sim.host)
    host, port = franka_sim.desk.rsplit(":", 1)
    auth = {"Authorization": "Basic " + base64.b64encode(b"franka:franka").decode()}

    def desk(path, body=None, token=None):
        connection = http.client.HTTPSConnection(host, int(port), timeout=30,
                                                 context=ssl._create_unverified_context())
        headers = dict(auth, **({"X-Control-Token": token} if token else {}))
        connection.request("POST", path, json.dumps(body) if body else None, headers)
        answer = connection.getresponse()
        data = answer.read()
        connection.close()
        assert answer.status == 200, data
        return json.loads(data) if data else None

    token = desk("/api/system/control-token:take", {"owner": "test", "timeout": 1})["token"]
    desk("/api/arm/joints:unlock", token=token)
    desk("/api/fci:activate", token=token)
    robot = connect(franka_sim.host)  # the FCI is active, but Programming holds the arm
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Other
    with pytest.raises(pylibfranka.CommandException, match="not possible"):
        robot.start_joint_position_control(JI)
    desk("/api/system/operating-mode:change", {"desiredOperatingMode": "Execution"}, token)
    # (in realtime, the socket may still hold states from before the change: read them out)
    for _ in range(5000):
        if robot.read_once().robot_mode == pylibfranka.RobotMode.Idle:
            break
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
    assert franka_sim.control.desk()["arm_ready"]


@pytest.mark.franka_sim(grip=False)
def test_a_misspelt_marker_setting_is_an_error(franka_sim):
    pass


def test_fails_and_shows_the_robot_log(franka_sim):
    record(franka_sim, "failing")
    robot = connect(franka_sim.host)
    robot.read_once()
    assert robot is None, "deliberately failing"


@pytest.mark.franka_sim(robot="fer")
def test_a_panda_reaches_what_an_fr3_cannot(franka_sim):
    record(franka_sim, "panda")
    assert franka_sim.control.health()["robot"] == "fer"
    robot = connect(franka_sim.host)
    control = robot.start_joint_position_control(JI)
    state, _ = control.readOnce()
    q = np.array(state.q_d)
    for k in range(1, 1001):  # joint 6 from 1.571 to 0.3 rad (an FR3 stops at 0.54) in 1 s
        state, _ = control.readOnce()
        s = 0.5 * (1 - np.cos(np.pi * k / 1000))
        command = pylibfranka.JointPositions((q + s * np.r_[0, 0, 0, 0, 0, 0.3 - q[5], 0]).tolist())
        command.motion_finished = k == 1000
        control.writeOnce(command)
    assert abs(robot.read_once().q[5] - 0.3) < 2e-3
    assert franka_sim.control.state()["errors"] == []
