"""A recording started and finished through the control API on a running server (what the
pytest plugin records each test with): it begins from a reset world at a late message_id, and
its replay in a fresh simulator is identical all the same."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import BadRequest, Conflict, Control
from franka_sim.recording.reader import open_recording
from franka_sim.testing import running_sim
from support.clients import connect, move_to
from support.replayed import identical_line


def _replay(path) -> str:
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout.strip()


def _client_gone(control: Control) -> None:
    end = time.monotonic() + 5
    while control.health()["client_connected"]:
        assert time.monotonic() < end, "the client did not leave"
        time.sleep(0.01)


def _busy_client(host: str, control: Control) -> None:
    """What an earlier test leaves: the arm moved, settings changed, the Hand closed, the cube
    moved."""
    robot = connect(host)
    robot.set_collision_behavior([30.0] * 7, [30.0] * 7, [30.0] * 6, [30.0] * 6)
    robot.set_load(0.5, [0.0, 0.0, 0.05], [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3])
    q0 = np.array(robot.read_once().q)
    move_to(robot, q0 + np.array([0.2, 0.1, 0, -0.2, 0, 0.2, 0.1]), 0.4)
    gripper = pylibfranka.Gripper(host)
    assert gripper.move(0.02, 0.1)
    del gripper
    control.set_pose("cube", [0.5, -0.1, 0.3])
    del robot
    _client_gone(control)


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_a_recording_started_on_a_running_server_replays_identical(clock, tmp_path):
    path = tmp_path / "test.mcap"
    with running_sim("--clock", clock, "--enforce-motion-limits") as sim:
        control = Control(sim.host)
        _busy_client(sim.host, control)
        control.reset()
        started = control.start_recording(path)
        assert started["path"] == str(path) and started["cycle"] > 400
        robot = connect(sim.host)
        q0 = np.array(robot.read_once().q)
        move_to(robot, q0 + np.array([0, 0.1, 0, -0.1, 0, 0, 0]), 0.3)
        robot.read_once()
        control.set_pose("cube", [0.45, 0.1, 0.3])
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.move(0.06, 0.1)
        del gripper, robot
        finished = control.finish_recording()
        assert finished["path"] == str(path) and finished["dropped"] == 0
        with pytest.raises(Conflict, match="no recording"):
            control.finish_recording()
    states = open_recording(path).states()
    assert int(states["message_id"][0]) > started["cycle"]
    assert _replay(path) == identical_line(open_recording(path))


def test_what_a_recording_start_refuses(tmp_path):
    with running_sim() as sim:
        control = Control(sim.host)
        with pytest.raises(BadRequest, match="cannot record to"):
            control.start_recording(tmp_path / "missing" / "x.mcap")
        robot = connect(sim.host)
        robot.read_once()
        with pytest.raises(Conflict, match="FCI client connected"):
            control.start_recording(tmp_path / "a.mcap")
        assert not (tmp_path / "a.mcap").exists()
        del robot
        _client_gone(control)
        control.start_recording(tmp_path / "b.mcap")
        with pytest.raises(Conflict, match="already recording"):
            control.start_recording(tmp_path / "b.mcap")
        control.finish_recording()
        assert len(open_recording(tmp_path / "b.mcap").of("control")) == 1  # its reset


def test_a_recording_under_way_is_finished_when_the_server_stops(tmp_path):
    with running_sim() as sim:
        Control(sim.host).start_recording(tmp_path / "c.mcap")
        connect(sim.host).read_once()
    assert _replay(tmp_path / "c.mcap").startswith("identical")


def test_a_served_recording_refuses_a_second(tmp_path):
    with running_sim("--record", str(tmp_path / "run.mcap")) as sim:
        with pytest.raises(Conflict, match="already recording"):
            Control(sim.host).start_recording(tmp_path / "d.mcap")
        with pytest.raises(Conflict, match="no recording started through the control API"):
            Control(sim.host).finish_recording()
