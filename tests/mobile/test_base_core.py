"""The mobile base's core, sans-IO: Move admission, the twist it follows, the swerve modules,
finishing, stopping, the planar reflex and its recovery."""

from __future__ import annotations

import math

import numpy as np
import pytest

from support.harness import move_request, reply_status
from franka_sim.description.mobile_base import (BASE_NAME, MAX_ACCELERATION, MAX_SPEED,
                                                WHEEL_RADIUS, base_urdf_text)
from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.protocol.enums import (Command, MotionGeneratorMode, MoveMotionGeneratorMode,
                                       MoveStatus, RobotMode)
from franka_sim.protocol.errors import error_index
from franka_sim.robot.base_cycle import BaseCycle
from franka_sim.robot.base_core import COMM_REFLEX, PLANAR_REFLEX, BaseCore
from franka_sim.robot.swerve import SwerveDrive

CARTESIAN_VELOCITY = int(MoveMotionGeneratorMode.kCartesianVelocity)


class Base:
    """A base core run cycle by cycle, as the server runs it."""

    def __init__(self, **settings) -> None:
        self.cycle = BaseCycle(BaseCore(base_urdf_text().encode(), **settings))
        self.replies: list[bytes] = []
        self.step()

    @property
    def core(self) -> BaseCore:
        return self.cycle.core

    def step(self, n: int = 1):
        for _ in range(n):
            released = self.cycle.release()
            self.state = decode_state(released.state)
            self.replies += self.cycle.complete(released).robot
        return self.state

    def request(self, command, request=None) -> list[tuple[int, int, int]]:
        return [reply_status(r) for r in self.core.handle(command, 7, request)]

    def move(self, generator=CARTESIAN_VELOCITY, controller=0):
        return self.request(Command.Move, move_request(controller, generator))

    def send(self, twist, finished=False, message_id=None) -> bool:
        """A command answering the last state (or the one `message_id` names)."""
        mid = int(self.state["message_id"]) if message_id is None else message_id
        command = np.frombuffer(encode_command(
            message_id=mid, O_dP_EE_c=list(twist),
            motion_generation_finished=finished), dtype=np.uint8)
        return self.cycle.receive(decode_command(command.tobytes()))

    def drive(self, twists) -> None:
        """Start a motion, then one twist per cycle."""
        assert self.move() == [(int(Command.Move), 7, int(MoveStatus.kMotionStarted))]
        self.step()  # the modes flip
        for twist in twists:
            assert self.send(twist)
            self.step()


def test_the_served_urdf_names_a_mobile_robot_with_four_module_joints():
    urdf = base_urdf_text()
    assert f'<robot name="{BASE_NAME}">' in urdf and BASE_NAME.startswith("tmr")
    for i in range(4):
        assert f'name="{BASE_NAME}_joint_{i}" type="continuous"' in urdf


def test_other_generators_and_torque_control_are_refused():
    base = Base()
    for generator in (MoveMotionGeneratorMode.kJointPosition,
                      MoveMotionGeneratorMode.kJointVelocity,
                      MoveMotionGeneratorMode.kCartesianPosition):
        assert base.move(int(generator)) == [
            (int(Command.Move), 7, int(MoveStatus.kCommandNotPossibleRejected))]
    assert base.move(CARTESIAN_VELOCITY, controller=2) == [  # kExternalController
        (int(Command.Move), 7, int(MoveStatus.kCommandNotPossibleRejected))]
    assert base.core.motion is None


def test_a_twist_moves_the_base_within_its_limits_and_steers_the_modules():
    base = Base()
    base.drive([(0.5, 0.0, 0.0, 0.0, 0.0, 0.0)] * 1000)
    state = base.state
    assert state["motion_generator_mode"] == MotionGeneratorMode.kCartesianVelocity
    assert state["robot_mode"] == RobotMode.kMove
    # 1 m/s² from rest: 0.5 m/s after 0.5 s, then steady: 0.125 + 0.25 m in the first second.
    assert state["O_dP_EE_d"][0] == pytest.approx(0.5)
    x = np.reshape(state["O_T_EE"], (4, 4), order="F")[0, 3]
    assert x == pytest.approx(0.5 * 0.5 * MAX_ACCELERATION * 0.5 ** 2 / 0.5 + 0.25, abs=2e-3)
    assert list(state["O_dP_EE_c"]) == [0.5, 0, 0, 0, 0, 0]
    assert state["q"][0] == 0.0 and state["q"][2] == 0.0  # steered straight ahead
    assert state["dq"][1] == pytest.approx(0.5 / WHEEL_RADIUS)  # both wheels roll
    assert state["dq"][3] == pytest.approx(0.5 / WHEEL_RADIUS)
    assert state["control_command_success_rate"] == 1.0


def test_a_sideways_twist_steers_both_modules_to_its_direction():
    drive = SwerveDrive()
    for _ in range(300):
        drive.step(0.1, 0.1, 0.0)
    assert drive.q[0] == pytest.approx(math.pi / 4) and drive.q[2] == pytest.approx(math.pi / 4)
    drive = SwerveDrive()
    for _ in range(300):
        drive.step(0.0, 0.0, 0.5)  # turning on the spot: the modules point opposite ways ...
    assert drive.q[0] == pytest.approx(math.pi / 2) and drive.q[2] == pytest.approx(-math.pi / 2)
    assert drive.dq[1] == pytest.approx(drive.dq[3]) and drive.dq[1] > 0  # ... both rolling
    assert drive.yaw > 0


def test_speed_is_limited():
    drive = SwerveDrive()
    for _ in range(5000):
        drive.step(5.0, 0.0, 0.0)
    assert drive.vx == pytest.approx(MAX_SPEED)


def test_a_finished_motion_is_answered_and_the_base_brakes_to_rest():
    base = Base()
    base.drive([(0.2, 0.0, 0.0, 0.0, 0.0, 0.0)] * 300)
    assert base.send((0.2, 0.0, 0.0, 0.0, 0.0, 0.0), finished=True)
    base.step()
    assert [reply_status(r) for r in base.replies] == [(int(Command.Move), 7,
                                                        int(MoveStatus.kSuccess))]
    assert base.state["motion_generator_mode"] == MotionGeneratorMode.kIdle
    assert base.state["robot_mode"] == RobotMode.kIdle
    assert base.cycle.busy  # still braking
    base.step(400)
    assert not base.cycle.busy and base.cycle.at_rest
    assert base.state["O_dP_EE_d"][0] == 0.0 and base.state["dq"][1] == 0.0


def test_a_twist_out_of_the_plane_is_a_reflex_that_recovery_clears():
    base = Base()
    base.drive([(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)] * 10)
    assert base.send((0.1, 0.0, 0.05, 0.0, 0.0, 0.0))
    base.step()
    assert [reply_status(r)[2] for r in base.replies] == [int(MoveStatus.kReflexAborted)]
    assert base.state["robot_mode"] == RobotMode.kReflex
    assert base.state["errors"][error_index(PLANAR_REFLEX)]
    assert base.request(Command.AutomaticErrorRecovery) == [
        (int(Command.AutomaticErrorRecovery), 7, 0)]
    base.step()
    assert base.state["robot_mode"] == RobotMode.kIdle and not base.state["errors"].any()


def test_stop_preempts_the_motion():
    base = Base()
    base.drive([(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)] * 10)
    assert base.request(Command.StopMove) == [(int(Command.Move), 7, int(MoveStatus.kPreempted)),
                                              (int(Command.StopMove), 7, 0)]
    assert base.step()["robot_mode"] == RobotMode.kIdle


def test_a_silent_client_leaves_the_base_braking():
    base = Base()
    base.drive([(0.3, 0.0, 0.0, 0.0, 0.0, 0.0)] * 400)
    base.step(19)  # extrapolated: the last twist holds
    assert base.state["O_dP_EE_d"][0] == pytest.approx(0.3, abs=1e-6)
    base.step()
    assert base.core.client_silent
    base.step(400)
    assert base.state["O_dP_EE_d"][0] == 0.0
    assert base.state["robot_mode"] == RobotMode.kMove  # until the client is heard again


def test_under_enforcement_a_silent_client_ends_the_motion_in_the_reflex():
    """--enforce-comm-constraints on the base as on an arm: 20 cycles lost in a row abort."""
    base = Base(enforce_comm_constraints=True)
    base.drive([(0.3, 0.0, 0.0, 0.0, 0.0, 0.0)] * 400)
    base.step(19)
    assert base.state["robot_mode"] == RobotMode.kMove
    base.step()
    assert [reply_status(r)[2] for r in base.replies] == [int(MoveStatus.kReflexAborted)]
    assert base.state["robot_mode"] == RobotMode.kReflex
    assert base.state["errors"][error_index(COMM_REFLEX)]
    base.request(Command.AutomaticErrorRecovery)
    base.step(400)
    assert base.state["robot_mode"] == RobotMode.kIdle and base.state["O_dP_EE_d"][0] == 0.0


def test_under_enforcement_a_client_gone_mid_motion_is_the_reflex():
    base = Base(enforce_comm_constraints=True)
    base.drive([(0.3, 0.0, 0.0, 0.0, 0.0, 0.0)] * 10)
    base.core.client_gone()
    assert base.step()["robot_mode"] == RobotMode.kReflex
    assert base.state["errors"][error_index(COMM_REFLEX)]


def test_a_client_heard_only_late_still_ends_the_base_motion():
    """Its answers all a cycle late (a slow link): dropped, the base brakes as for a silent
    client; the finish, sent again each cycle by libfranka, ends the motion all the same."""
    base = Base()
    base.drive([(0.2, 0.0, 0.0, 0.0, 0.0, 0.0)] * 50)
    for k in range(30):
        answered = int(base.state["message_id"])
        base.step()
        assert not base.send((0.2, 0.0, 0.0, 0.0, 0.0, 0.0), finished=k >= 25,
                             message_id=answered)  # late
    base.step()
    assert [reply_status(r)[2] for r in base.replies] == [int(MoveStatus.kSuccess)]
    assert base.state["robot_mode"] == RobotMode.kIdle
