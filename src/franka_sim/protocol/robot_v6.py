"""Robot protocol 6 (libfranka 0.10 to 0.12): version 5 without GetCartesianLimit, so its ids
from SetCollisionBehavior on are one lower (protocol_specs/robot_v5.md, "Version 6"); statuses,
the RobotCommand and the RobotState are v5's."""

from __future__ import annotations

from enum import IntEnum

from construct import Enum, Int32ul, Struct

from . import robot_v5

VERSION = 6


class Command(IntEnum):
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
    SetFilters = 10
    AutomaticErrorRecovery = 11
    LoadModelLibrary = 12


CommandHeader = Struct(
    "command" / Enum(Int32ul, Command),
    "command_id" / Int32ul,
    "size" / Int32ul,
)
REQUEST_STRUCTS = robot_v5._requests(Command, CommandHeader)
REQUEST_SIZES = {c: s.sizeof() for c, s in REQUEST_STRUCTS.items()}
LoadModelLibraryRequest = REQUEST_STRUCTS[Command.LoadModelLibrary]


class Dialect(robot_v5.Dialect):
    version = VERSION
    commands = Command
    header = CommandHeader
    request_sizes = REQUEST_SIZES
    request_structs = REQUEST_STRUCTS
