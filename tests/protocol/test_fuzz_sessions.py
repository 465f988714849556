"""The TCP conversations against hostile clients, with the real state machines behind them: no
exception but the session's own SessionError (the server closes that connection) comes out,
every reply is a response the protocol defines, the states the robot publishes stay legal,
and the next client is served."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from support.fuzzing import FUZZ, DrawChooser

from franka_sim.protocol.enums import Command, GripperCommand, VacuumGripperCommand
from franka_sim.testing.fuzz_inputs import (GRIPPER_WIRE, ROBOT_WIRE, VACUUM_GRIPPER_WIRE,
                                            RandomChooser, request)
from franka_sim.testing.fuzz_targets import (GripperTarget, RobotTarget, VacuumGripperTarget,
                                             fuzz_session)


@FUZZ
@given(st.data())
def test_robot_session_enforcing_limits(data):
    fuzz_session(DrawChooser(data), RobotTarget(enforce_motion_limits=True))


@FUZZ
@given(st.data())
def test_robot_session_logging_limits(data):
    fuzz_session(DrawChooser(data), RobotTarget(enforce_motion_limits=False))


@FUZZ
@given(st.data())
def test_gripper_session(data):
    fuzz_session(DrawChooser(data), GripperTarget())


@FUZZ
@given(st.data())
def test_vacuum_gripper_session(data):
    fuzz_session(DrawChooser(data), VacuumGripperTarget())


class _Fixed:
    """A chooser that always takes the lowest choice: the plainest message of a kind."""

    def integer(self, low: int, high: int) -> int:
        return low

    def raw(self, max_size: int) -> bytes:
        return b""


def _valid(wire, command) -> bytes:
    data = request(_Fixed(), wire, command, command_id=7)
    if command == wire.connect:
        return data[:-4] + wire.version.to_bytes(2, "little") + data[-2:]
    return data


@pytest.mark.parametrize("target, wire, first", [
    (RobotTarget, ROBOT_WIRE, Command.Move),
    (RobotTarget, ROBOT_WIRE, Command.GetRobotModel),
    (GripperTarget, GRIPPER_WIRE, GripperCommand.Homing),
    (VacuumGripperTarget, VACUUM_GRIPPER_WIRE, VacuumGripperCommand.Vacuum),
])
def test_request_before_connect_closes(target, wire, first):
    t = target()
    t.open()
    t.tcp(_valid(wire, first))
    assert t.session.closed and t.replies == []
    t.close()
    t.still_serves()


@pytest.mark.parametrize("target, wire", [(RobotTarget, ROBOT_WIRE), (GripperTarget, GRIPPER_WIRE),
                                          (VacuumGripperTarget, VACUUM_GRIPPER_WIRE)])
def test_second_connect_closes(target, wire):
    t = target()
    t.open()
    t.tcp(_valid(wire, wire.connect))
    t.tcp(_valid(wire, wire.connect))
    assert t.session.closed and len(t.replies) == 1
    t.close()
    t.still_serves()


@pytest.mark.parametrize("target, wire, then", [
    (RobotTarget, ROBOT_WIRE, Command.StopMove),
    (GripperTarget, GRIPPER_WIRE, GripperCommand.Stop),
    (VacuumGripperTarget, VACUUM_GRIPPER_WIRE, VacuumGripperCommand.Stop),
])
def test_nothing_is_answered_after_a_bad_header(target, wire, then):
    t = target()
    t.open()
    t.tcp(_valid(wire, wire.connect))
    bad = bytearray(_valid(wire, then))
    bad[wire.size_offset] ^= 0x40  # the size lies
    t.tcp(bytes(bad) + _valid(wire, then))
    t.tcp(_valid(wire, then))
    assert t.session.closed and len(t.replies) == 1  # the Connect's only
    t.close()
    t.still_serves()


@pytest.mark.parametrize("seed", [259803, 514803])
def test_inputs_found_by_the_long_run(seed):
    """Found by benchmarks/fuzz.py: a SetLoad with a centre of mass ~1e143 m away was accepted
    and made the physics unstable; such a load is now refused (kInvalidArgumentRejected)."""
    fuzz_session(RandomChooser(seed), RobotTarget(enforce_motion_limits=True))
