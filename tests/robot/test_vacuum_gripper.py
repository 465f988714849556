"""The vacuum gripper's state machine on its own (robot/vacuum_gripper.py): requests in, the
pump's command out, the cup's readings in, answers and states out; clocked by cycle numbers
alone."""

from __future__ import annotations

import pytest

from franka_sim.physics.suction import MAX_VACUUM, CupState, SuctionCommand
from franka_sim.protocol.enums import VacuumGripperCommand as C
from franka_sim.protocol.enums import VacuumGripperDeviceStatus
from franka_sim.protocol.framing import FrameReader, decode_request
from franka_sim.protocol.vacuum_gripper_messages import (
    VACUUM_GRIPPER_REQUEST_SIZES, VACUUM_GRIPPER_REQUEST_STRUCTS, VacuumGripperCommandResponse,
    VacuumGripperHeader, build_vacuum_gripper_request, decode_vacuum_gripper_state)
from franka_sim.robot.vacuum_gripper import STATE_PERIOD, VacuumGripper


def ask(pump, command, command_id=1, **fields) -> list[bytes]:
    """A request as the session hands it over (decoded from the client's bytes)."""
    raw = build_vacuum_gripper_request(command, command_id, **fields)
    frame, = FrameReader(VacuumGripperHeader, VACUUM_GRIPPER_REQUEST_SIZES, 1024).feed(raw)
    return pump.request(command, command_id,
                        decode_request(frame, VACUUM_GRIPPER_REQUEST_STRUCTS))


def statuses(replies) -> list[tuple[int, str]]:
    out = []
    for r in replies:
        parsed = VacuumGripperCommandResponse.parse(r)
        out.append((parsed.header.command_id, str(parsed.status)))
    return out


class Cup:
    """A stand-in for physics/suction.py's cup: seals when told, draws at the pump's rate."""

    def __init__(self, part: bool = True) -> None:
        self.part, self.vacuum = part, 0.0

    def step(self, command: SuctionCommand) -> CupState:
        if not self.part:
            return CupState(0.0, False, command.setpoint > 0, None)
        if command.vent:
            self.vacuum = max(0.0, self.vacuum - 5.0)
        elif command.setpoint > 0:
            self.vacuum = min(min(command.setpoint, MAX_VACUUM), self.vacuum + 2.5)
        sealed = self.vacuum > 0 or (command.setpoint > 0 and not command.vent)
        return CupState(self.vacuum, sealed, self.vacuum < command.setpoint, "cube")


def run(pump, cup, cycles) -> list[bytes]:
    replies, command = [], SuctionCommand()
    for _ in range(cycles):
        command = pump.command or command
        pump.advance(pump.cycle + 1, cup.step(command))
        replies += pump.take_replies()
    return replies


def test_vacuum_answers_once_the_part_is_present_and_holds_it():
    pump, cup = VacuumGripper(), Cup()
    assert ask(pump, C.Vacuum, 7, vacuum=60, profile="kP1", timeout=1000) == []
    assert pump.command == SuctionCommand(600.0) and pump.busy
    replies = run(pump, cup, 400)
    assert statuses(replies) == [(7, "kSuccess")]
    # 70 % of 600 mbar is 420 mbar, reached at 2.5 mbar a cycle: the 168th cycle
    assert pump.part_present and pump.in_control_range and not pump.busy
    assert pump.command == SuctionCommand(600.0)  # it keeps the setpoint
    state = decode_vacuum_gripper_state(pump.pack_state(pump.cycle))
    assert state.vacuum == 600 and state.part_present and state.actual_power == 0
    assert state.device_status == "kGreen" and state.message_id == 400


def test_a_setpoint_beyond_the_pump_is_the_most_it_draws():
    pump = VacuumGripper()
    ask(pump, C.Vacuum, vacuum=100, profile="kP0", timeout=1000)  # libfranka's example: 1 bar
    assert pump.setpoint == MAX_VACUUM


def test_vacuum_on_nothing_times_out_unsuccessful_and_stops_the_pump():
    pump, cup = VacuumGripper(), Cup(part=False)
    ask(pump, C.Vacuum, 3, vacuum=50, profile="kP0", timeout=250)
    replies = run(pump, cup, 249)
    assert replies == [] and pump.actual_power == 100  # an open cup: flat out
    assert statuses(run(pump, cup, 1)) == [(3, "kUnsuccessful")]
    assert pump.command == SuctionCommand() and not pump.part_present


def test_drop_off_vents_and_says_the_part_came_off():
    pump, cup = VacuumGripper(), Cup()
    ask(pump, C.Vacuum, 1, vacuum=50, profile="kP0", timeout=1000)
    run(pump, cup, 300)
    assert ask(pump, C.DropOff, 2, timeout=1000) == []
    assert pump.command == SuctionCommand(vent=True)
    replies = run(pump, cup, 200)
    assert statuses(replies) == [(2, "kSuccess")]
    assert pump.part_detached and not pump.part_present and not pump.in_control_range
    assert pump.command == SuctionCommand()
    # the next Vacuum clears part_detached
    ask(pump, C.Vacuum, 3, vacuum=50, profile="kP0", timeout=1000)
    assert not pump.part_detached


def test_a_part_lost_while_held_turns_the_device_yellow_until_stop():
    pump, cup = VacuumGripper(), Cup()
    ask(pump, C.Vacuum, 1, vacuum=50, profile="kP0", timeout=1000)
    run(pump, cup, 300)
    cup.part, cup.vacuum = False, 0.0  # torn off
    run(pump, cup, 1)
    assert pump.device_status is VacuumGripperDeviceStatus.kYellow and not pump.part_present
    assert pump.actual_power == 100
    assert statuses(ask(pump, C.Stop, 9)) == [(9, "kSuccess")]
    assert pump.device_status is VacuumGripperDeviceStatus.kGreen
    assert pump.command == SuctionCommand()


def test_stop_and_a_new_action_abort_the_running_one():
    pump, cup = VacuumGripper(), Cup(part=False)
    ask(pump, C.Vacuum, 1, vacuum=50, profile="kP0", timeout=5000)
    run(pump, cup, 10)
    assert statuses(ask(pump, C.DropOff, 2, timeout=100)) == [(1, "kAborted")]
    assert statuses(ask(pump, C.Stop, 3)) == [(2, "kAborted"), (3, "kSuccess")]
    assert pump.idle


@pytest.mark.parametrize("command, fields", [
    (C.Vacuum, {"vacuum": 0, "profile": "kP0", "timeout": 100}),
    (C.Vacuum, {"vacuum": 50, "profile": "kP0", "timeout": -1}),
    (C.Vacuum, {"vacuum": 50, "profile": 7, "timeout": 100}),
    (C.DropOff, {"timeout": -5}),
])
def test_bad_arguments_are_refused_with_kfail_and_change_nothing(command, fields, caplog):
    pump = VacuumGripper()
    assert statuses(ask(pump, command, 4, **fields)) == [(4, "kFail")]
    assert pump.idle and pump.command is None
    assert "refused (kFail)" in caplog.text


def test_states_go_out_at_10_hz_with_the_cycle_as_their_time():
    pump = VacuumGripper()
    due = [c for c in range(1, 1001) if pump.state_due(c)]
    assert due == list(range(STATE_PERIOD, 1001, STATE_PERIOD)) and STATE_PERIOD == 100


def test_skipped_cycles_move_a_deadline_with_them():
    pump, cup = VacuumGripper(), Cup(part=False)
    ask(pump, C.Vacuum, 1, vacuum=50, profile="kP0", timeout=100)
    pump.skip(1000)
    assert run(pump, cup, 99) == []
    assert statuses(run(pump, cup, 1)) == [(1, "kUnsuccessful")]


def test_a_client_gone_leaves_the_part_held():
    pump, cup = VacuumGripper(), Cup()
    ask(pump, C.Vacuum, 1, vacuum=50, profile="kP0", timeout=1000)
    run(pump, cup, 100)  # still drawing: the answer is due
    pump.client_gone()
    assert pump.idle and pump.take_replies() == []
    run(pump, cup, 300)
    assert pump.command == SuctionCommand(500.0) and pump.part_present
    assert pump.take_replies() == []
