"""Several arms in one world, each driven by its own unmodified pylibfranka program (one process
per arm, as a user runs two arms): they move at once, touch each other, and one client dying
leaves the other's motion untouched. Lockstep, so the outcomes do not depend on this machine."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "arm_program.py"


@contextmanager
def two_arms(*args: str, left_at: str = "", right_at: str = "", clock: str = "lockstep"):
    left, right = fresh_loopback_address(), fresh_loopback_address()
    server = ServerProcess(left, "--arm", f"left={left}{left_at}", "--arm",
                           f"right={right}{right_at}", "--scene", "dual_arm_table",
                           "--clock", clock, *args).wait_ready()
    try:
        yield server, left, right
    finally:
        server.stop()


def start(host: str, delta, seconds: float, threshold: float = 20.0,
          together: bool = False) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(PROGRAM), host, json.dumps(list(delta)),
                             str(seconds), str(threshold)] + (["--together"] if together else []),
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def at_once(*programs: subprocess.Popen) -> list[subprocess.Popen]:
    """Programs started `together`: once every one is connected, their motions start at once
    (a process that took longer to start would otherwise move its arm after the other's)."""
    for program in programs:
        assert program.stdout.readline().strip() == "ready"
    for program in programs:
        program.stdin.write("\n")
        program.stdin.flush()
    return list(programs)


def result(program: subprocess.Popen) -> dict:
    out, err = program.communicate(timeout=120)
    assert program.returncode == 0, out + err
    return json.loads(out.strip().splitlines()[-1])


def joint1(angle: float) -> list[float]:
    return [angle, 0, 0, 0, 0, 0, 0]


def test_two_clients_move_their_arms_at_once_and_each_reaches_its_target():
    with two_arms() as (server, left, right):
        right_before = Control(right).state()
        alone = result(start(left, joint1(0.3), 1.0))
        # The left arm moved alone: the right one did not move a bit.
        assert Control(right).state()["q"] == right_before["q"]
        assert alone["error"] == "" and alone["min_rate"] == 1.0
        programs = [start(left, joint1(-0.3), 1.5), start(right, joint1(-0.4), 1.0)]
        outcomes = [result(p) for p in programs]
    for outcome in outcomes:
        assert outcome["error"] == ""
        assert outcome["min_rate"] == 1.0  # lockstep: the world waits for both answers
        np.testing.assert_allclose(outcome["q"], outcome["target"], atol=2e-3)
    assert outcomes[0]["q"][0] == pytest.approx(0.0, abs=2e-3)  # +0.3 then -0.3


def test_each_arm_reports_in_its_own_base_frame():
    with two_arms() as (server, left, right):
        poses = [np.array(Control(host).state()["O_T_EE"]) for host in (left, right)]
    # Same joint angles, bases 0.7 m apart: the same pose, each in its own base frame.
    np.testing.assert_allclose(poses[0], poses[1], atol=1e-12)


def test_arms_driven_into_each_other_both_feel_it_and_the_reflex_stops_them():
    # Bases 0.6 m apart; turning joint 1 by 0.9 rad towards each other brings the Hands
    # together at about 0.75 rad.
    with two_arms(left_at="@0,0.3,0", right_at="@0,-0.3,0") as (server, left, right):
        programs = at_once(start(left, joint1(-0.9), 2.0, together=True),
                           start(right, joint1(0.9), 2.0, together=True))
        outcomes = [result(p) for p in programs]
        states = [Control(host).state() for host in (left, right)]
    for outcome, state in zip(outcomes, states):
        # Symmetric, so both go over their thresholds: each stops with its own reflex, judged
        # on its own external force, short of the target the other arm was in the way of.
        assert "aborted by reflex" in outcome["error"], outcome
        assert "cartesian_reflex" in outcome["errors"] or "joint_reflex" in outcome["errors"]
        assert 0.6 < abs(outcome["q"][0]) < 0.85
        assert state["robot_mode"] == "Reflex"


def test_contact_is_judged_with_each_arms_own_thresholds():
    # The same contact as above, but the left arm's client set thresholds far above what the
    # press reaches: only the right arm stops with a reflex; the left one feels the contact in
    # its external torque and ends its motion without an error (pushing the stopped arm aside).
    with two_arms(left_at="@0,0.3,0", right_at="@0,-0.3,0") as (server, left, right):
        programs = at_once(start(left, joint1(-0.9), 2.0, threshold=1000.0, together=True),
                           start(right, joint1(0.9), 2.0, together=True))
        outcomes = [result(p) for p in programs]
        states = [Control(host).state() for host in (left, right)]
    held_on, stopped = outcomes
    assert "aborted by reflex" in stopped["error"] and states[1]["robot_mode"] == "Reflex"
    assert held_on["error"] == "" and states[0]["robot_mode"] == "Idle"
    assert held_on["max_tau_ext"] > 20.0  # over the right arm's threshold, under its own
    assert stopped["max_tau_ext"] > 0.0


def test_a_client_killed_mid_motion_leaves_the_other_arms_motion_untouched():
    with two_arms() as (server, left, right):
        doomed = start(left, joint1(0.5), 5.0)
        assert doomed.stdout.readline().strip() == "started"
        survivor = start(right, joint1(-0.5), 2.0)
        assert survivor.stdout.readline().strip() == "started"
        doomed.send_signal(signal.SIGKILL)
        doomed.wait(10)
        outcome = result(survivor)
        left_state = Control(left).state()
        assert not left_state["robot_mode"] == "Move"  # the lost client's motion was stopped
        again = result(start(left, joint1(0.1), 0.5))  # and the next client is served at once
    assert outcome["error"] == "" and outcome["min_rate"] == 1.0
    np.testing.assert_allclose(outcome["q"], outcome["target"], atol=2e-3)
    assert again["error"] == ""
