"""Robot protocol 6 (libfranka 0.10 to 0.12): v7's commands, ids and statuses (robot_v7.py;
neither GetCartesianLimit nor SetFilters, both safety statuses) with v5's RobotCommand of 370
bytes and no kNone generator (protocol_specs/robot_v5.md, "Version 6"). The version went to 6
with GetCartesianLimit gone; SetFilters went and the safety statuses came before libfranka
0.10.0 took that `common` commit, so no released client speaks v5's other differences as 6."""

from __future__ import annotations

from . import robot_v5, robot_v7

VERSION = 6

Command = robot_v7.Command
CommandHeader = robot_v7.CommandHeader
REQUEST_STRUCTS = robot_v7.REQUEST_STRUCTS
REQUEST_SIZES = robot_v7.REQUEST_SIZES
LoadModelLibraryRequest = REQUEST_STRUCTS[Command.LoadModelLibrary]


class Dialect(robot_v7.Dialect):
    """v7's, but the 370-byte RobotCommand read as v10's (as v5's)."""

    version = VERSION
    command = robot_v5.Dialect.command
