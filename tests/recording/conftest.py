"""Recorded pylibfranka sessions, made once per clock and shared by the recording tests."""

from __future__ import annotations

import numpy as np
import pylibfranka
import pytest

from franka_sim.control.client import Control
from franka_sim.testing import running_sim
from support.clients import connect, move_to

JI = pylibfranka.ControllerMode.JointImpedance


def _reflex(robot) -> None:
    """A step in q_c: a velocity discontinuity the robot (enforcing its limits) aborts on."""
    control = robot.start_joint_position_control(JI)
    first, _ = control.readOnce()
    with pytest.raises(pylibfranka.ControlException):
        for k in range(1000):
            control.readOnce()
            q = np.array(first.q_d)
            q[3] += 0.05 if k > 5 else 0.0
            control.writeOnce(pylibfranka.JointPositions(q.tolist()))
    del control


def record_session(path, clock: str) -> list:
    """A pylibfranka session (a motion, a reflex, its recovery, the Hand, control calls) on a
    recording server; the states the client read, as (message_id, q, dq, tau_J, robot_mode)."""
    seen = []

    def keep(state):
        seen.append((round(state.time.to_sec() * 1000), np.array(state.q), np.array(state.dq),
                     np.array(state.tau_J), int(state.robot_mode.value)))

    with running_sim("--record", str(path), "--clock", clock, "--enforce-motion-limits") as sim:
        robot = connect(sim.host)
        keep(robot.read_once())
        q0 = np.array(robot.read_once().q)
        move_to(robot, q0 + np.array([0.1, 0, 0, -0.1, 0, 0.1, 0]), 0.5)
        keep(robot.read_once())
        _reflex(robot)
        keep(robot.read_once())
        robot.automatic_error_recovery()
        keep(robot.read_once())
        Control(sim.host).set_pose("cube", [0.45, 0.1, 0.45])
        Control(sim.host).push("link7", force=[0, 0, -20], duration=0.2)  # the client idle
        keep(robot.read_once())
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.move(0.04, 0.1)
        del gripper
        move_to(robot, q0, 0.3)
        for _ in range(3):
            keep(robot.read_once())
        del robot
    return seen


@pytest.fixture(scope="session")
def lockstep_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("lockstep") / "run.mcap"
    return path, record_session(path, "lockstep")


@pytest.fixture(scope="session")
def realtime_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("realtime") / "run.mcap"
    return path, record_session(path, "realtime")
