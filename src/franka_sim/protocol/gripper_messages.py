"""Franka Hand messages (TCP port 1338 + UDP state, protocol v3).

Same idea as the robot protocol but a different header (command is uint16, so the header is
10 bytes), uint16 statuses, and a 23-byte state datagram.
"""

from typing import Any

from construct import Enum, Flag, Float64l, Int16ul, Int32ul, Struct

from .enums import GripperCommand, GripperConnectStatus, GripperStatus
from .message import build_message, message

GripperHeader = Struct(
    "command" / Enum(Int16ul, GripperCommand),
    "command_id" / Int32ul,
    "size" / Int32ul,  # whole message, header included
)
GRIPPER_HEADER_SIZE = 10
assert GripperHeader.sizeof() == GRIPPER_HEADER_SIZE

GripperConnectRequest = message(GripperHeader, "version" / Int16ul, "udp_port" / Int16ul)
GripperHomingRequest = message(GripperHeader)
GripperGraspRequest = message(
    GripperHeader,
    "width" / Float64l,
    "epsilon_inner" / Float64l,
    "epsilon_outer" / Float64l,
    "speed" / Float64l,
    "force" / Float64l,
)
GripperMoveRequest = message(GripperHeader, "width" / Float64l, "speed" / Float64l)
GripperStopRequest = message(GripperHeader)

GripperConnectResponse = message(
    GripperHeader, "status" / Enum(Int16ul, GripperConnectStatus), "version" / Int16ul
)
# Homing, Grasp, Move and Stop all answer with just a status.
GripperCommandResponse = message(GripperHeader, "status" / Enum(Int16ul, GripperStatus))

GripperState = Struct(
    "message_id" / Int32ul,  # read by the client as milliseconds
    "width" / Float64l,
    "max_width" / Float64l,
    "is_grasped" / Flag,
    "temperature" / Int16ul,
)
GRIPPER_STATE_SIZE = 23
assert GripperState.sizeof() == GRIPPER_STATE_SIZE

GRIPPER_REQUEST_STRUCTS: dict[GripperCommand, Struct] = {
    GripperCommand.Connect: GripperConnectRequest,
    GripperCommand.Homing: GripperHomingRequest,
    GripperCommand.Grasp: GripperGraspRequest,
    GripperCommand.Move: GripperMoveRequest,
    GripperCommand.Stop: GripperStopRequest,
}

GRIPPER_RESPONSE_STRUCTS: dict[GripperCommand, Struct] = {
    GripperCommand.Connect: GripperConnectResponse,
    GripperCommand.Homing: GripperCommandResponse,
    GripperCommand.Grasp: GripperCommandResponse,
    GripperCommand.Move: GripperCommandResponse,
    GripperCommand.Stop: GripperCommandResponse,
}

GRIPPER_REQUEST_SIZES: dict[GripperCommand, int] = {
    cmd: s.sizeof() for cmd, s in GRIPPER_REQUEST_STRUCTS.items()
}


def build_gripper_request(command: GripperCommand, command_id: int, **fields: Any) -> bytes:
    """Bytes of a gripper request as a client sends it (for tests and Python clients)."""
    struct = GRIPPER_REQUEST_STRUCTS[GripperCommand(command)]
    return build_message(struct, command, command_id, fields)


def build_gripper_response(
    command: GripperCommand, command_id: int, status: int, **extra: Any
) -> bytes:
    """Bytes of the response to a gripper ``command``; Connect also takes ``version``."""
    struct = GRIPPER_RESPONSE_STRUCTS[GripperCommand(command)]
    return build_message(struct, command, command_id, {"status": status, **extra})
