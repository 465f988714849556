"""Robot protocol 8 (libfranka 0.14): on the wire v9's exactly (robot_v9.py,
protocol_specs/robot_v9.md); the version 9 changed nothing a client sends or reads. A v8
client takes its dynamics from the URDF and its kinematics from the model library, as v9's."""

from __future__ import annotations

from . import robot_v9

VERSION = 8


class Dialect(robot_v9.Dialect):
    version = VERSION
