"""The vacuum gripper (Cobot Pump) behind protocol v1: a state machine clocked by the robot's
cycle number, the arm's tool device (robot/tool.py; its cup: physics/suction.py).

No sockets, threads or wall time. Vacuum, DropOff and Stop come in through `request()`; after
every step the arm's cycle calls `advance(cycle, cup)` with the cup's sensor. Vacuum and
DropOff are answered when they are done or their timeout ran out (libfranka blocks until then);
a VacuumGripperState goes out whenever `state_due(cycle)`.

What the device reports (docs/tools.md; figures ours where not said otherwise):
- vacuum: the cup's, in mbar, rounded; actual_power: 100 % while the pump draws air (an open
  cup, or a sealed one below its setpoint), 0 once the setpoint is held.
- The setpoint is the request's `vacuum` × 10 mbar, at most the pump's MAX_VACUUM (a client
  asking for more, as libfranka's example does with 1000 mbar, gets the most the pump draws).
- in_control_range: the vacuum within CONTROL_BAND of the setpoint; part_present: above
  PRESENT_FRACTION of the setpoint, until it falls PRESENT_HYSTERESIS below that.
- Vacuum answers kSuccess once the part is present and the vacuum in range, and holds it (the
  pump keeps the setpoint); kUnsuccessful at its timeout (the pump stops: nothing sealed).
- DropOff vents the cup: kSuccess once the cup is at ambient, part_detached then says whether a
  part was held; kUnsuccessful at its timeout.
- Stop ends a running action (which answers kAborted) and idles the pump; a sealed part stays
  held by the vacuum left in the cup (the seal does not leak).
- device_status: kGreen; kYellow while a held part's vacuum has fallen out of its range (the
  pump running flat out: a leak, a part pulled off), until the next Vacuum, DropOff or Stop.
- Bad arguments (a setpoint of 0, a negative timeout, a profile beyond P3) answer kFail,
  libfranka's CommandException.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from franka_sim.physics.suction import MAX_VACUUM, CupState, SuctionCommand
from franka_sim.protocol.enums import (VacuumGripperCommand, VacuumGripperDeviceStatus,
                                       VacuumGripperProfile, VacuumGripperStatus)
from franka_sim.protocol.vacuum_gripper_messages import (build_vacuum_gripper_response,
                                                         pack_vacuum_gripper_state)

log = logging.getLogger(__name__)

STATE_PERIOD = 100  # cycles between states: 10 Hz, as the Hand's
SETPOINT_UNIT = 10.0  # mbar per unit of the request's `vacuum`
CONTROL_BAND = 0.2  # in control range: within this fraction below the setpoint
PRESENT_FRACTION = 0.7  # part present above this fraction of the setpoint...
PRESENT_HYSTERESIS = 10.0  # mbar: ...until it falls this far below it
OPEN_CUP = CupState(0.0, False, False, None)


@dataclass
class _Action:
    kind: VacuumGripperCommand
    command_id: int
    deadline: int  # the last cycle it may succeed on
    had_part: bool = False  # DropOff: a part was present as it began


class VacuumGripper:
    """The pump: its setpoint, the running action, and what it reports (a tool device)."""

    kind = "vacuum"

    def __init__(self, *, state_period: int = STATE_PERIOD) -> None:
        self.state_period = state_period
        self.cycle = 0
        self.setpoint = 0.0  # mbar the pump holds (0: none asked for yet)
        self.cup = OPEN_CUP
        self.in_control_range = self.part_present = self.part_detached = False
        self.device_status = VacuumGripperDeviceStatus.kGreen
        self._holding = False  # a Vacuum succeeded and the pump keeps its setpoint
        self._action: _Action | None = None
        self._command: SuctionCommand | None = None
        self._replies: list[bytes] = []

    # -- the cycle ---------------------------------------------------------------------------
    @property
    def idle(self) -> bool:
        return self._action is None

    @property
    def busy(self) -> bool:
        return self._action is not None

    @property
    def command(self) -> SuctionCommand | None:
        return self._command

    def advance(self, cycle: int, cup: CupState | None) -> None:
        self.cycle = cycle
        if cup is None:
            return
        dropping = self._action is not None and self._action.kind is VacuumGripperCommand.DropOff
        if self.cup.sealed and not cup.sealed and not dropping:
            log.info("vacuum gripper: the part %s came off: %s", self.cup.part, cup.lost)
        self.cup = cup
        self._judge(cup.vacuum)
        if self._holding and not self.in_control_range:
            self.device_status = VacuumGripperDeviceStatus.kYellow
        action = self._action
        if action is None:
            return
        if action.kind is VacuumGripperCommand.Vacuum:
            done = self.part_present and self.in_control_range
        else:
            done = not cup.sealed
        if done:
            if action.kind is VacuumGripperCommand.Vacuum:
                self._holding = True
            else:
                self.part_detached = action.had_part
                self._command = SuctionCommand()
            self._answer(VacuumGripperStatus.kSuccess)
        elif cycle >= action.deadline:
            log.info("vacuum gripper %s: timed out (vacuum %.0f mbar)", action.kind.name,
                     cup.vacuum)
            self._command = SuctionCommand()
            self._answer(VacuumGripperStatus.kUnsuccessful)

    def _judge(self, vacuum: float) -> None:
        """in_control_range and part_present from the vacuum (hysteresis on the latter)."""
        s = self.setpoint
        self.in_control_range = s > 0.0 and vacuum >= (1.0 - CONTROL_BAND) * s
        threshold = PRESENT_FRACTION * s
        if s <= 0.0:
            self.part_present = False
        elif self.part_present:
            self.part_present = vacuum >= threshold - PRESENT_HYSTERESIS
        else:
            self.part_present = vacuum >= threshold

    def _answer(self, status: VacuumGripperStatus) -> None:
        action, self._action = self._action, None
        self._replies.append(build_vacuum_gripper_response(action.kind, action.command_id,
                                                           status))

    def skip(self, cycles: int) -> None:
        self.cycle += cycles
        if self._action is not None:
            self._action.deadline += cycles

    def state_due(self, cycle: int) -> bool:
        return cycle % self.state_period == 0

    def pack_state(self, cycle: int) -> bytes:
        return pack_vacuum_gripper_state(
            message_id=cycle & 0xFFFFFFFF, in_control_range=self.in_control_range,
            part_detached=self.part_detached, part_present=self.part_present,
            device_status=int(self.device_status), actual_power=self.actual_power,
            vacuum=round(self.cup.vacuum))

    @property
    def actual_power(self) -> int:
        return 100 if self.cup.pumping else 0

    def snapshot(self) -> dict:
        """What the control API and the status line show."""
        return {"vacuum": round(self.cup.vacuum, 1), "setpoint": self.setpoint,
                "in_control_range": self.in_control_range, "part_present": self.part_present,
                "part_detached": self.part_detached, "device_status": self.device_status.name,
                "actual_power": self.actual_power, "part": self.cup.part}

    def take_replies(self) -> list[bytes]:
        replies, self._replies = self._replies, []
        return replies

    # -- requests ----------------------------------------------------------------------------
    def request(self, command: VacuumGripperCommand, command_id: int, request) -> list[bytes]:
        if command is VacuumGripperCommand.Stop:
            replies = self._abort_running()
            self._holding, self._command = False, SuctionCommand()
            self.device_status = VacuumGripperDeviceStatus.kGreen
            return replies + [build_vacuum_gripper_response(command, command_id,
                                                            VacuumGripperStatus.kSuccess)]
        timeout = int(request.timeout)
        if command is VacuumGripperCommand.Vacuum:
            problem = self._check_vacuum(int(request.vacuum), request.profile, timeout)
        elif command is VacuumGripperCommand.DropOff:
            problem = "" if timeout >= 0 else f"timeout {timeout} ms is negative"
        else:
            raise AssertionError(f"unhandled vacuum gripper command {command!r}")
        if problem:
            log.warning("vacuum gripper %s refused (kFail): %s", command.name, problem)
            return [build_vacuum_gripper_response(command, command_id,
                                                  VacuumGripperStatus.kFail)]
        replies = self._abort_running()
        self._holding = False
        self.device_status = VacuumGripperDeviceStatus.kGreen
        action = _Action(command, command_id, self.cycle + max(1, timeout))
        if command is VacuumGripperCommand.Vacuum:
            self.setpoint = min(SETPOINT_UNIT * int(request.vacuum), MAX_VACUUM)
            self.part_detached = False
            self._command = SuctionCommand(self.setpoint)
        else:
            action.had_part = self.cup.sealed
            self._command = SuctionCommand(vent=True)
        self._action = action
        return replies

    @staticmethod
    def _check_vacuum(vacuum: int, profile, timeout: int) -> str:
        if vacuum <= 0:
            return "a setpoint of 0 mbar holds nothing"
        if timeout < 0:
            return f"timeout {timeout} ms is negative"
        if not isinstance(profile, str) or profile not in VacuumGripperProfile.__members__:
            return f"profile {int(profile)} is none of P0-P3"
        return ""

    def _abort_running(self) -> list[bytes]:
        action, self._action = self._action, None
        if action is None:
            return []
        return [build_vacuum_gripper_response(action.kind, action.command_id,
                                              VacuumGripperStatus.kAborted)]

    def reset(self, reading: CupState) -> None:
        """As the pump starts: idle, nothing asked for, the cup as `reading` has it."""
        if self._action is not None:
            raise ValueError("a vacuum gripper action is under way")
        cycle = self.cycle
        self.__init__(state_period=self.state_period)
        self.cycle, self.cup = cycle, reading

    def client_gone(self) -> None:
        """Nobody waits for answers; the pump goes on with what it does (a held part stays)."""
        self._replies.clear()
        self._action = None
