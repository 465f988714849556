"""Robot protocol 7 (libfranka 0.13): v8's without GetRobotModel (it came with 8), so a v7
client takes its whole Model (kinematics and dynamics) from the model library
(protocol_specs/robot_v9.md, "Versions 7 and 8")."""

from __future__ import annotations

from enum import IntEnum

from construct import Enum, Int32ul, Struct

from . import robot_v9
from .message import message

VERSION = 7


class Command(IntEnum):
    """Robot TCP command ids of v7 (uint32 on the wire)."""

    Connect = 0
    Move = 1
    StopMove = 2
    SetCollisionBehavior = 3
    SetJointImpedance = 4
    SetCartesianImpedance = 5
    SetGuidingMode = 6
    SetEEToK = 7
    SetNEToEE = 8
    SetLoad = 9
    AutomaticErrorRecovery = 10
    LoadModelLibrary = 11


CommandHeader = Struct(
    "command" / Enum(Int32ul, Command),
    "command_id" / Int32ul,
    "size" / Int32ul,
)
REQUEST_STRUCTS: dict[Command, Struct] = {
    Command[c.name]: message(CommandHeader, *s.subcons[1:])
    for c, s in robot_v9.REQUEST_STRUCTS.items() if c.name in Command.__members__}
REQUEST_SIZES: dict[Command, int] = {c: s.sizeof() for c, s in REQUEST_STRUCTS.items()}


class Dialect(robot_v9.Dialect):
    version = VERSION
    commands = Command
    header = CommandHeader
    request_sizes = REQUEST_SIZES
    request_structs = REQUEST_STRUCTS
