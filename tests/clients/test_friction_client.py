"""The joints' residual friction (physics/friction.py), through pylibfranka torque control: an
arm commanded zero torque holds still, and one set turning by a torque pulse and then
commanded zero torque comes to rest and holds still, as a real FR3 does, instead of turning
on for ever; and libfranka's force_control example,
ported, presses on the table for 60 s within its 1 cm guard, in both clocks."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.physics.friction import JointFriction
from franka_sim.testing import running_sim
from support.clients import connect

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PULSE = (2.0, 0.1)  # Nm on joint 1, for s: sets the arm turning at a few tenths of a rad/s
HOLD_DRIFT = 1e-4  # rad: the most any joint may move in 10 s of zero torque from rest


def _pulse_then_zero_torque(robot, seconds: float, pulse: float = PULSE[0]):
    """Torque control: `pulse` Nm on joint 1 for PULSE[1] s, then zero torque; q and dq
    (n, 7) as read each cycle."""
    control = robot.start_torque_control()
    control.readOnce()
    t, q, dq = 0.0, [], []
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        q.append(state.q)
        dq.append(state.dq)
        command = pylibfranka.Torques([pulse if t < PULSE[1] else 0.0] + [0.0] * 6)
        command.motion_finished = t >= seconds
        control.writeOnce(command)
        if command.motion_finished:
            return np.array(q), np.array(dq)


def test_an_arm_set_turning_then_left_alone_comes_to_rest_and_holds_still():
    """Without friction the pulse's 0.2 N·m·s would turn joint 1 on at its speed (≈ 3 rad in
    10 s); with it, the arm coasts a little and stops."""
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        q, dq = _pulse_then_zero_torque(robot, 10.0 + PULSE[1])
        del robot
    q1, dq1 = q[:, 0], dq[:, 0]
    pulse_end = int(PULSE[1] * 1000)
    assert dq1[pulse_end] > 0.1  # the pulse set it turning,
    assert q1[-1] - q1[pulse_end] < 0.3  # it coasted a few degrees,
    assert abs(dq1[-1]) < 1e-3  # came to rest,
    assert abs(q1[-1] - q1[-1000]) < 1e-3  # and held still over the last second


def test_zero_torque_from_rest_holds_still_for_ten_seconds():
    """The torque-control hold still: zero torque for 10 s from the ready pose (the robot adds
    gravity compensation) leaves every joint within HOLD_DRIFT of where it started."""
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        q, _ = _pulse_then_zero_torque(robot, 10.0, pulse=0.0)
        del robot
    assert len(q) >= 10_000
    assert np.abs(q - q[0]).max() < HOLD_DRIFT


def test_friction_resists_motion_and_is_zero_at_rest():
    friction, out = JointFriction(), np.zeros(7)
    assert not friction.at(np.zeros(7), out).any()
    turning = friction.at(np.full(7, 0.5), out).copy()
    assert (turning > 0).all() and (friction.at(np.full(7, -0.5), out) < 0).all()
    assert (turning < 1.3).all()  # saturates near phi1 (at most 1.28 Nm, joint 4)


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_force_control_presses_for_a_minute_within_its_guard(clock):
    with running_sim("--clock", clock) as sim:
        done = subprocess.run([sys.executable, str(EXAMPLES / "force_control.py"), sim.host,
                               "60"], capture_output=True, text=True, timeout=300)
    out = done.stdout + done.stderr
    assert done.returncode == 0, out
    assert "Finished: held the force for 60.0" in out
    drift = float(re.search(r"largest drift (\S+) mm", out).group(1))
    assert drift < 10.0  # the example's own guard: it gives up 1 cm from where it started
