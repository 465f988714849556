"""Robot protocol 7 (libfranka 0.13): v8's without GetRobotModel (it came with 8), so a v7
client takes its whole Model (kinematics and dynamics) from the model library
(protocol_specs/robot_v9.md, "Versions 7 and 8")."""

from __future__ import annotations

from enum import IntEnum

from . import robot_v9
from .message import command_header, renumbered

VERSION = 7


# Robot TCP command ids of v7 (uint32 on the wire): v9's without GetRobotModel.
Command = IntEnum("Command", [(c.name, c.value) for c in robot_v9.Command
                              if c is not robot_v9.Command.GetRobotModel], module=__name__)
CommandHeader = command_header(Command)
REQUEST_STRUCTS: dict = renumbered(robot_v9.REQUEST_STRUCTS, Command, CommandHeader)
REQUEST_SIZES: dict[Command, int] = {c: s.sizeof() for c, s in REQUEST_STRUCTS.items()}


class Dialect(robot_v9.Dialect):
    version = VERSION
    commands = Command
    header = CommandHeader
    request_sizes = REQUEST_SIZES
    request_structs = REQUEST_STRUCTS
