"""The Desk through the real clients (franky 2.0.0's Desk and DeskWebSession, franka-desk 0.1.0,
franka-deskapi 1.0.1), each in a child Python (tests/support/desk_programs.py), against a
simulator that boots locked: a bring-up lets pylibfranka connect and move, a tear-down has it
refused again, and a second client's take waits for the holder or the Pilot. One simulator for
the module; a reset before each test starts its Desk again as it boots."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import Control

from desk.conftest import PASSWORD, PORT, USER, locked_desk
from support.clients import connect, move_to

PROGRAMS = Path(__file__).resolve().parent.parent / "support" / "desk_programs.py"
REFUSED = "Connection to FCI refused"


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    with locked_desk(tmp_path_factory) as sim:
        yield sim


@pytest.fixture
def sim(served):
    Control(served.host).reset()
    return served


class Program:
    """A desk_programs.py program in a child Python, read line by line."""

    def __init__(self, name: str, host: str, arg: str = "", home: Path | None = None) -> None:
        env = dict(os.environ)
        # requests lets these override `verify=False`, which franka-desk relies on to accept
        # a robot's self-signed certificate (as a lab machine without them does).
        env.pop("REQUESTS_CA_BUNDLE", None)
        env.pop("CURL_CA_BUNDLE", None)
        if home is not None:
            env["HOME"] = str(home)
        self.proc = subprocess.Popen(
            [sys.executable, str(PROGRAMS), name, f"{host}:{PORT}", USER, PASSWORD, arg or "-"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env=env)

    def expect(self, word: str) -> list[str]:
        """The next line that starts with `word` (its other words), skipping the rest (WAIT,
        and what a client prints itself, such as franky's prompt to press the button). A
        program silent for 120 s is ended and its stderr shown (a net against a hung client,
        not a timing bound: every step here takes well under a second)."""
        timer = threading.Timer(120.0, self.proc.kill)
        timer.start()
        try:
            return self._expect(word)
        finally:
            timer.cancel()

    def _expect(self, word: str) -> list[str]:
        while True:
            line = self.proc.stdout.readline()
            if not line:
                self.proc.wait(30)
                raise AssertionError(f"the program ended before {word}: {self.proc.stderr.read()}")
            words = line.split()
            if words and words[0] == word:
                return words[1:]

    def go(self) -> None:
        self.proc.stdin.write("\n")
        self.proc.stdin.flush()

    def finish(self) -> None:
        assert self.proc.wait(60) == 0, self.proc.stderr.read()


def _refused(host: str) -> str:
    with pytest.raises(pylibfranka.NetworkException) as refused:
        connect(host)
    return str(refused.value)


def _moves(host: str) -> None:
    robot = connect(host)
    q0 = np.array(robot.read_once().q)
    assert str(robot.read_once().robot_mode) == "RobotMode.Idle"
    target = q0 + np.array([0.05, 0, 0, 0, 0, 0, 0])
    q = move_to(robot, target, seconds=0.5)
    assert np.allclose(q, target, atol=2e-3)
    del robot


def _motion_refused(host: str) -> str:
    robot = connect(host)
    assert str(robot.read_once().robot_mode) == "RobotMode.Other"
    with pytest.raises(pylibfranka.CommandException) as refused:
        robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    del robot
    return str(refused.value)


@pytest.mark.parametrize("program", ["franky_desk", "franka_desk", "deskapi"])
def test_bring_up_from_locked_then_tear_down(sim, program, tmp_path):
    assert REFUSED in _refused(sim.host)
    client = Program(program, sim.host, home=tmp_path)
    if program == "franky_desk":
        assert client.expect("CHECKED") == ["None"]
    up = client.expect("UP")
    assert "Active" in up and "Execution" in up
    _moves(sim.host)
    client.go()
    client.expect("DOWN")
    client.finish()
    assert REFUSED in _refused(sim.host)
    desk = Control(sim.host).desk()
    assert (desk["brakes"], desk["fci"], desk["control_token"]) == ("Locked", "Inactive", None)


def test_the_older_desk_brings_up_and_its_locked_brakes_refuse_a_motion(sim):
    client = Program("franky_web_session", sim.host)
    assert client.expect("UP") == ["Unlocked", "Execution"]
    _moves(sim.host)
    client.go()
    assert client.expect("DOWN") == ["Locked"]
    client.finish()
    # The older Desk's clients never deactivate the FCI: it stays open, the brakes refuse.
    assert "command not possible" in _motion_refused(sim.host)


def test_the_control_api_locks_the_brakes_as_at_the_robot(sim):
    control = Control(sim.host)
    assert REFUSED in _refused(sim.host)
    holder = Program("franky_desk", sim.host)
    holder.expect("UP")
    control.desk_arm(brakes="Locked")
    assert "command not possible" in _motion_refused(sim.host)
    control.desk_arm(brakes="Unlocked")
    _moves(sim.host)
    holder.go()
    holder.finish()


def test_brakes_locked_mid_motion_abort_it_and_the_log_says_why(sim):
    control = Control(sim.host)
    holder = Program("franky_desk", sim.host)
    holder.expect("UP")
    robot = connect(sim.host)
    motion = robot.start_torque_control()
    motion.readOnce()
    motion.writeOnce(pylibfranka.Torques([0.0] * 7))
    control.desk_arm(brakes="Locked")
    with pytest.raises(pylibfranka.ControlException, match="aborted"):
        for _ in range(10_000):  # (each cycle answered until the robot ends the motion)
            motion.readOnce()
            motion.writeOnce(pylibfranka.Torques([0.0] * 7))
    assert any("Move aborted: the Desk locked the brakes" in line for line in sim.sync())
    del robot
    control.desk_arm(brakes="Unlocked")
    holder.go()
    holder.finish()


def test_a_second_take_fails_until_released(sim):
    first = Program("franky_take", sim.host, "wait:5")
    assert first.expect("TOOK") == ["True"]
    second = Program("franky_take", sim.host, "wait:1")
    assert second.expect("REFUSED") == ["TakeControlTimeoutError"]
    second.finish()
    waiting = Program("franky_take", sim.host, "wait:60")
    control = Control(sim.host)
    _until(lambda: control.desk()["pending_request"] is not None)
    first.go()  # releases: the waiting take is granted
    assert first.expect("STILL") == ["True"]
    first.finish()
    assert waiting.expect("TOOK") == ["True"]
    waiting.go()
    waiting.finish()


def test_a_forced_take_needs_the_pilots_button(sim):
    control = Control(sim.host)
    holder = Program("franky_take", sim.host, "wait:5")
    holder.expect("TOOK")
    forcing = Program("franky_take", sim.host, "force:60")
    _until(lambda: (control.desk()["pending_request"] or {}).get("force"))
    control.press_pilot_button("cross")
    assert control.desk()["control_token"]["owner"] == USER
    pending = control.desk()["pending_request"]["id"]
    control.press_pilot_button("circle")
    assert control.desk()["control_token"]["id"] == pending
    assert forcing.expect("TOOK") == ["True"]
    holder.go()
    assert holder.expect("STILL") == ["False"]
    holder.finish()
    forcing.go()
    forcing.finish()


def test_pilot_buttons_reach_a_listening_client(sim):
    listener = Program("franky_pilot", sim.host)
    listener.expect("LISTENING")
    Control(sim.host).press_pilot_button("check")
    assert json.loads(" ".join(listener.expect("EVENTS"))) == [["check", True], ["check", False]]
    listener.finish()


def _until(condition, limit: float = 60.0) -> None:
    """Poll the simulator's state until `condition` (the limit is a net against a dead
    process, not a timing bound of the test)."""
    end = time.monotonic() + limit
    while not condition():
        assert time.monotonic() < end, "the condition never came"
        time.sleep(0.02)
