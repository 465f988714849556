"""Robot protocol 5 (libfranka 0.9, the Panda's), as it differs from 7 (robot_v7.py).

Restated from libfranka-common's service_types.h and rbk_types.h at the commit that made the
version 5 (libfranka 0.9.2's `common` submodule); protocol_specs/robot_v5.md:
- command ids: GetCartesianLimit (3) and SetFilters (11) exist, so every later id is shifted
  (SetCollisionBehavior 4 … SetLoad 10, AutomaticErrorRecovery 12, LoadModelLibrary 13);
- status enums lack kCommandRejectedDueToActivatedSafetyFunctions (and Move's
  kPreemptedDueToActivatedSafetyFunctions), so the values after them are shifted: the v10
  robot's statuses are written by name, a status v5 has no name for as the nearest it has;
- the RobotCommand has no torque_command_finished (370 bytes): torque control is a Move of the
  external controller with the joint velocity generator held at zero, ended by
  motion_generation_finished, which v10 serves as such;
- there is no kNone generator; the RobotState is v7's (and v9's).
GetCartesianLimit (a virtual wall's figures; this robot has none configured) and SetFilters
(the robot's own low-pass filters of the commands; the simulator takes commands as sent) are
answered kSuccess; docs/deviations.md says so.
"""

from __future__ import annotations

import logging
from enum import IntEnum

from construct import Array, Enum, Flag, Float64l, Int8ul, Int32sl, Struct

from . import enums as v10
from . import robot_v9
from .message import build_message, command_header, message, renumbered

VERSION = 5
log = logging.getLogger(__name__)


class Command(IntEnum):
    Connect = 0
    Move = 1
    StopMove = 2
    GetCartesianLimit = 3
    SetCollisionBehavior = 4
    SetJointImpedance = 5
    SetCartesianImpedance = 6
    SetGuidingMode = 7
    SetEEToK = 8
    SetNEToEE = 9
    SetLoad = 10
    SetFilters = 11
    AutomaticErrorRecovery = 12
    LoadModelLibrary = 13


class GetterSetterStatus(IntEnum):
    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kInvalidArgumentRejected = 2


class MoveStatus(IntEnum):
    kSuccess = 0
    kMotionStarted = 1
    kPreempted = 2
    kCommandNotPossibleRejected = 3
    kStartAtSingularPoseRejected = 4
    kInvalidArgumentRejected = 5
    kReflexAborted = 6
    kEmergencyAborted = 7
    kInputErrorAborted = 8
    kAborted = 9


class StopMoveStatus(IntEnum):
    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kEmergencyAborted = 2
    kReflexAborted = 3
    kAborted = 4


class AutomaticErrorRecoveryStatus(IntEnum):
    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kManualErrorRecoveryRequiredRejected = 2
    kReflexAborted = 3
    kEmergencyAborted = 4
    kAborted = 5


CommandHeader = command_header(Command)
GetCartesianLimitRequest = message(CommandHeader, "id" / Int32sl)
GetCartesianLimitResponse = message(
    CommandHeader,
    "status" / Enum(Int8ul, GetterSetterStatus),
    "object_world_size" / Array(3, Float64l),
    "object_frame" / Array(16, Float64l),  # column-major
    "object_activation" / Flag,
)
SetFiltersRequest = message(
    CommandHeader,
    "joint_position_filter_frequency" / Float64l,
    "joint_velocity_filter_frequency" / Float64l,
    "cartesian_position_filter_frequency" / Float64l,
    "cartesian_velocity_filter_frequency" / Float64l,
    "controller_filter_frequency" / Float64l,
)
SetFiltersResponse = message(CommandHeader, "status" / Enum(Int8ul, GetterSetterStatus))


def _requests(commands: type[IntEnum], header: Struct) -> dict:  # (v6 too)
    """Every request of `commands`: v7's layouts under these ids, and the two v7 dropped."""
    return {**renumbered(robot_v9.REQUEST_STRUCTS, commands, header),
            **renumbered({Command.GetCartesianLimit: GetCartesianLimitRequest,
                          Command.SetFilters: SetFiltersRequest}, commands, header)}


REQUEST_STRUCTS = _requests(Command, CommandHeader)
REQUEST_SIZES = {c: s.sizeof() for c, s in REQUEST_STRUCTS.items()}
LoadModelLibraryRequest = REQUEST_STRUCTS[Command.LoadModelLibrary]
# A reply's status as v5 numbers it (Move's here; the other tables are above).
MoveResponse = message(CommandHeader, "status" / Enum(Int8ul, MoveStatus))
ROBOT_COMMAND_SIZE = 370  # v10's without torque_command_finished


def _by_name(older: type[IntEnum], newer: type[IntEnum], nearest: dict) -> dict[int, int]:
    """A v10 status value → the value v5 gives the same name (or the nearest's)."""
    return {int(s): int(older[nearest.get(s.name, s.name)]) for s in newer}


_SAFETY = {"kCommandRejectedDueToActivatedSafetyFunctions": "kCommandNotPossibleRejected"}
# By the v10 command a reply answers: (v5's status enum, v10's, the nearest v5 name of a v10
# name v5 lacks).
_STATUS_ENUMS = {
    v10.Command.Move: (MoveStatus, v10.MoveStatus, {
        **_SAFETY, "kPreemptedDueToActivatedSafetyFunctions": "kPreempted"}),
    v10.Command.StopMove: (StopMoveStatus, v10.StopMoveStatus, _SAFETY),
    v10.Command.AutomaticErrorRecovery: (
        AutomaticErrorRecoveryStatus, v10.AutomaticErrorRecoveryStatus, _SAFETY),
    **{c: (GetterSetterStatus, v10.GetterSetterStatus, _SAFETY) for c in (
        v10.Command.SetCollisionBehavior, v10.Command.SetJointImpedance,
        v10.Command.SetCartesianImpedance, v10.Command.SetGuidingMode, v10.Command.SetEEToK,
        v10.Command.SetNEToEE, v10.Command.SetLoad)},
}
# Its status values as v5's, and back (a v5 value as the v10 status of the same name).
_STATUSES = {c: _by_name(*enums) for c, enums in _STATUS_ENUMS.items()}
_UNSTATUSES = {c: {int(older[s.name]): int(s) for s in newer if s.name in older.__members__}
               for c, (older, newer, _) in _STATUS_ENUMS.items()}


class Dialect(robot_v9.Dialect):
    """How the v10 robot serves a v5 client (and, with its own ids, a v6 one: robot_v6.py)."""

    version = VERSION
    commands = Command
    header = CommandHeader
    request_sizes = REQUEST_SIZES
    request_structs = REQUEST_STRUCTS

    def reply(self, data: bytes) -> bytes:
        """A v10 reply as this version writes it: its command id and its status by name."""
        v10_id = int.from_bytes(data[:4], "little")
        statuses = _STATUSES.get(v10_id)
        wire = int(self.commands[v10.Command(v10_id).name]).to_bytes(4, "little")
        if statuses is None:
            return wire + data[4:]
        return wire + data[4:12] + bytes([statuses[data[12]]]) + data[13:]

    own_replies = {**robot_v9.Dialect.own_replies, "GetCartesianLimit": GetCartesianLimitResponse,
                   "SetFilters": SetFiltersResponse}

    def unreply(self, data: bytes) -> bytes:
        """A reply this version wrote, as v10 wrote it: its id and its status by name."""
        data = super().unreply(data)
        statuses = _UNSTATUSES.get(int.from_bytes(data[:4], "little"))
        return data if statuses is None else data[:12] + bytes([statuses[data[12]]]) + data[13:]

    def command(self, data: bytes) -> bytes:
        """A RobotCommand as v10's: torque_command_finished (absent in this version) false;
        any other size is left for the endpoint to refuse."""
        return data + b"\0" if len(data) == ROBOT_COMMAND_SIZE else data

    def answer(self, command, command_id: int, request, library) -> bytes:
        """The requests v10 has no equivalent of: LoadModelLibrary (as v9), GetCartesianLimit
        (no virtual wall is configured: zeros, inactive) and SetFilters (taken: commands are
        not filtered here)."""
        if command.name == "GetCartesianLimit":
            return build_message(GetCartesianLimitResponse, command, command_id, {
                "status": GetterSetterStatus.kSuccess, "object_world_size": [0.0] * 3,
                "object_frame": [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0],
                "object_activation": False})
        if command.name == "SetFilters":
            log.info("SetFilters taken: the simulator does not filter commands")
            return build_message(SetFiltersResponse, command, command_id,
                                 {"status": GetterSetterStatus.kSuccess})
        return super().answer(command, command_id, request, library)
