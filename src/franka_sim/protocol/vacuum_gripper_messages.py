"""Vacuum gripper (Cobot Pump) messages: TCP port 1339 + UDP state, protocol v1
(protocol_specs/vacuum_gripper_v1.md).

The Hand's conversation (10-byte header with a uint16 command, uint16 statuses) with its own
commands: timeouts travel as int64 milliseconds, and the state datagram is 16 bytes.
"""

from typing import Any

from construct import Enum, Flag, Int8ul, Int16ul, Int32sl, Int32ul, Int64sl, Struct

from .enums import (VacuumGripperCommand, VacuumGripperConnectStatus,
                    VacuumGripperDeviceStatus, VacuumGripperProfile, VacuumGripperStatus)
from .message import build_message, message

VacuumGripperHeader = Struct(
    "command" / Enum(Int16ul, VacuumGripperCommand),
    "command_id" / Int32ul,
    "size" / Int32ul,  # whole message, header included
)
VACUUM_GRIPPER_HEADER_SIZE = 10
assert VacuumGripperHeader.sizeof() == VACUUM_GRIPPER_HEADER_SIZE

VacuumGripperConnectRequest = message(VacuumGripperHeader, "version" / Int16ul,
                                      "udp_port" / Int16ul)
VacuumGripperVacuumRequest = message(
    VacuumGripperHeader,
    "vacuum" / Int8ul,  # the setpoint, in units of 10 mbar
    "profile" / Enum(Int8ul, VacuumGripperProfile),
    "timeout" / Int64sl,  # ms
)
VacuumGripperDropOffRequest = message(VacuumGripperHeader, "timeout" / Int64sl)  # ms
VacuumGripperStopRequest = message(VacuumGripperHeader)

VacuumGripperConnectResponse = message(
    VacuumGripperHeader, "status" / Enum(Int16ul, VacuumGripperConnectStatus),
    "version" / Int16ul)
# Vacuum, DropOff and Stop all answer with just a status.
VacuumGripperCommandResponse = message(VacuumGripperHeader,
                                       "status" / Enum(Int16ul, VacuumGripperStatus))

VacuumGripperState = Struct(
    "message_id" / Int32ul,  # read by the client as milliseconds
    "in_control_range" / Flag,
    "part_detached" / Flag,
    "part_present" / Flag,
    "device_status" / Enum(Int8ul, VacuumGripperDeviceStatus),
    "actual_power" / Int32sl,  # % of the pump's power
    "vacuum" / Int32sl,  # mbar below ambient
)
VACUUM_GRIPPER_STATE_SIZE = 16
assert VacuumGripperState.sizeof() == VACUUM_GRIPPER_STATE_SIZE

VACUUM_GRIPPER_REQUEST_STRUCTS: dict[VacuumGripperCommand, Struct] = {
    VacuumGripperCommand.Connect: VacuumGripperConnectRequest,
    VacuumGripperCommand.Vacuum: VacuumGripperVacuumRequest,
    VacuumGripperCommand.DropOff: VacuumGripperDropOffRequest,
    VacuumGripperCommand.Stop: VacuumGripperStopRequest,
}

VACUUM_GRIPPER_RESPONSE_STRUCTS: dict[VacuumGripperCommand, Struct] = {
    VacuumGripperCommand.Connect: VacuumGripperConnectResponse,
    VacuumGripperCommand.Vacuum: VacuumGripperCommandResponse,
    VacuumGripperCommand.DropOff: VacuumGripperCommandResponse,
    VacuumGripperCommand.Stop: VacuumGripperCommandResponse,
}

VACUUM_GRIPPER_REQUEST_SIZES: dict[VacuumGripperCommand, int] = {
    cmd: s.sizeof() for cmd, s in VACUUM_GRIPPER_REQUEST_STRUCTS.items()
}


def build_vacuum_gripper_request(command: VacuumGripperCommand, command_id: int,
                                 **fields: Any) -> bytes:
    """Bytes of a vacuum gripper request as a client sends it (for tests and Python clients)."""
    struct = VACUUM_GRIPPER_REQUEST_STRUCTS[VacuumGripperCommand(command)]
    return build_message(struct, command, command_id, fields)


def build_vacuum_gripper_response(command: VacuumGripperCommand, command_id: int, status: int,
                                  **extra: Any) -> bytes:
    """Bytes of the response to a vacuum gripper `command`; Connect also takes `version`."""
    struct = VACUUM_GRIPPER_RESPONSE_STRUCTS[VacuumGripperCommand(command)]
    return build_message(struct, command, command_id, {"status": status, **extra})


def pack_vacuum_gripper_state(**fields: Any) -> bytes:
    return VacuumGripperState.build(fields)


def decode_vacuum_gripper_state(data: bytes):
    """A VacuumGripperState datagram's fields (for tests and Python clients)."""
    return VacuumGripperState.parse(data)
