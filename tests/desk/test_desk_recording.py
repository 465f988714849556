"""A recorded run keeps its Desk calls: each change a log line, the arm's hold a control event
at its cycle, and its replay in a fresh simulator (booted as the run was) is identical."""

from __future__ import annotations

import base64
import http.client
import json
import ssl
import subprocess
import sys

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import Control
from franka_sim.protocol.enums import RobotMode
from franka_sim.recording.reader import open_recording
from franka_sim.testing import running_sim

from support.clients import connect, move_to
from support.replayed import identical_line

PORT = 8443
BASIC = {"Authorization": "Basic " + base64.b64encode(b"franka:franka").decode()}


def _desk(host, path, token=None, body=None) -> dict | None:
    connection = http.client.HTTPSConnection(host, PORT, timeout=30,
                                             context=ssl._create_unverified_context())
    headers = dict(BASIC, **({"X-Control-Token": token} if token else {}))
    connection.request("POST", path, body=None if body is None else json.dumps(body),
                       headers=headers)
    response = connection.getresponse()
    data = response.read()
    connection.close()
    assert response.status == 200, data
    return json.loads(data) if data else None


def test_a_desk_bring_up_is_recorded_and_replays_identical(tmp_path):
    path = tmp_path / "desk.mcap"
    with running_sim("--clock", "lockstep", "--record", str(path), "--desk-port", str(PORT),
                     "--desk-boot", "locked", "--control-port", "1340",
                     env={"XDG_DATA_HOME": str(tmp_path)}) as sim:
        token = _desk(sim.host, "/api/system/control-token:take",
                      body={"owner": "lab", "timeout": 1})["token"]
        _desk(sim.host, "/api/arm/joints:unlock", token)
        _desk(sim.host, "/api/system/operating-mode:change", token,
              {"desiredOperatingMode": "Execution"})
        _desk(sim.host, "/api/fci:activate", token)
        robot = connect(sim.host)
        q0 = np.array(robot.read_once().q)
        move_to(robot, q0 + np.array([0, 0.1, 0, -0.1, 0, 0, 0]), 0.3)
        _desk(sim.host, "/api/arm/joints:lock", token)
        assert str(robot.read_once().robot_mode) == "RobotMode.Other"
        with pytest.raises(pylibfranka.CommandException):
            robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
        del robot
        Control(sim.host).health()
    recording = open_recording(path)
    holds = [e.json() for e in recording.of("control") if e.json()["operation"] == "desk_arm"]
    assert [h["arguments"]["brakes"] for h in holds] == ["Unlocked", "Locked"]
    said = [e.json()["message"] for e in recording.of("log")]
    assert any("POST /api/fci:activate" in line for line in said)
    states = recording.states()
    modes = [RobotMode(m) for m in states["robot_mode"]]
    # (a state is sent to a connected client only: after the bring-up)
    assert modes[0] is RobotMode.kIdle and RobotMode.kMove in modes
    assert modes[-1] is RobotMode.kOther  # locked again
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.stdout.strip() == identical_line(recording), done.stdout + done.stderr
