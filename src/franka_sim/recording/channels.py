"""What a recording holds: one channel per kind of event, each with a schema that tools
(Foxglove, `mcap` readers) decode by field name.

The 1 kHz streams (RobotState, RobotCommand, GripperState) are stored as their wire bytes: the
FCI's layout is packed little-endian with fixed-size arrays, which is exactly ROS 1's message
serialization, so a `ros1msg` schema generated from the codec's dtype names every field and
recording a state costs no encoding. Rare events (TCP requests, control calls, poses, log
lines) are JSON with a JSON schema.

Topics carry the robot's name (`/fr3/robot_state`; `/left/...`, `/right/...`, `/base/...` in a
world of several robots), so each robot's traffic is under its own prefix; what belongs to the
world (its free bodies' poses, the cycles that repeated without a step, log lines) is not.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from franka_sim.protocol.codec import (COMMAND_DTYPE, GRIPPER_STATE_DTYPE, STATE_DTYPE,
                                       VACUUM_GRIPPER_STATE_DTYPE)

METADATA_NAME = "franka-sim"

_ROS1_TYPES = {"f8": "float64", "f4": "float32", "u1": "uint8", "u2": "uint16", "u4": "uint32",
               "u8": "uint64", "i1": "int8", "i2": "int16", "i4": "int32", "i8": "int64",
               "b1": "bool"}


def ros1_definition(dtype: np.dtype) -> str:
    """The ros1msg text whose serialization is the packed bytes of `dtype`."""
    lines = []
    for name in dtype.names:
        field = dtype.fields[name][0]
        base, shape = (field.base, field.shape) if field.subdtype else (field, ())
        kind = _ROS1_TYPES[f"{base.kind}{base.itemsize}"]
        count = int(np.prod(shape)) if shape else 0
        lines.append(f"{kind}[{count}] {name}" if count else f"{kind} {name}")
    return "\n".join(lines) + "\n"


# A recorded command: which cycle was open when the core took it, whether that cycle had
# completed (so replay hands it over at the same point), and its fate; then the datagram.
COMMAND_PREFIX = struct.Struct("<Q??")
COMMAND_PREFIX_DEFINITION = "uint64 cycle\nbool completed\nbool on_time\n"


def _object(**properties) -> bytes:
    return json.dumps({"type": "object", "properties": properties}).encode()


_NUM, _INT, _STR, _BOOL = ({"type": "number"}, {"type": "integer"}, {"type": "string"},
                           {"type": "boolean"})
_ANY = {}


class Channel:
    """A topic, its schema and encoding."""

    def __init__(self, topic: str, schema_name: str, schema_encoding: str, schema: bytes,
                 message_encoding: str) -> None:
        self.topic, self.schema_name = topic, schema_name
        self.schema_encoding, self.schema = schema_encoding, schema
        self.message_encoding = message_encoding


def _ros1(topic: str, name: str, definition: str) -> Channel:
    return Channel(topic, name, "ros1msg", definition.encode(), "ros1")


def _json(topic: str, name: str, schema: bytes) -> Channel:
    return Channel(topic, name, "jsonschema", schema, "json")


ROBOT_KEYS = ("robot_state", "command", "gripper_state", "vacuum_gripper_state",
              "command_rejected", "lost_cycle", "tcp", "reply", "control")
# Each tool service's state datagrams, by the service's name: their channel's key.
TOOL_STATE_KEYS = {"gripper": "gripper_state", "vacuum_gripper": "vacuum_gripper_state"}
WORLD_KEYS = ("bodies", "repeated", "skipped", "log")


def robot_channels(robot: str) -> dict[str, Channel]:
    """Every channel of one robot of a recording, by key."""
    p = f"/{robot}"
    return {
        "robot_state": _ros1(f"{p}/robot_state", "franka/RobotState", ros1_definition(STATE_DTYPE)),
        "command": _ros1(f"{p}/command", "franka/RecordedCommand",
                         COMMAND_PREFIX_DEFINITION + ros1_definition(COMMAND_DTYPE)),
        "gripper_state": _ros1(f"{p}/gripper_state", "franka/GripperState",
                               ros1_definition(GRIPPER_STATE_DTYPE)),
        "vacuum_gripper_state": _ros1(f"{p}/vacuum_gripper_state", "franka/VacuumGripperState",
                                      ros1_definition(VACUUM_GRIPPER_STATE_DTYPE)),
        "command_rejected": _json(f"{p}/command_rejected", "franka_sim/RejectedDatagram", _object(
            reason=_STR, source=_STR, size=_INT, data=_STR)),
        "lost_cycle": _json(f"{p}/lost_cycle", "franka_sim/LostCycle", _object(
            cycle=_INT, extrapolated=_BOOL, filled=_STR)),
        "tcp": _json(f"{p}/tcp", "franka_sim/TcpEvent", _object(
            cycle=_INT, completed=_BOOL, service=_STR, event=_STR, data=_STR,
            requests={"type": "array"}, replies={"type": "array"})),
        "reply": _json(f"{p}/reply", "franka_sim/Reply", _object(
            cycle=_INT, service=_STR, replies={"type": "array"})),
        "control": _json(f"{p}/control", "franka_sim/ControlCall", _object(
            cycle=_INT, completed=_BOOL, operation=_STR, arguments=_ANY, status=_INT,
            result=_ANY)),
    }


def world_channels() -> dict[str, Channel]:
    """The channels of the world a recording's robots share, by key."""
    return {
        "bodies": _json("/world/bodies", "franka_sim/BodyPoses", _object(
            cycle=_INT, qpos={"type": "array", "items": _NUM}, bodies={"type": "array"})),
        # Cycles that left the world as it was (lockstep's idle time, a motion's start held
        # for its client's first command): replay repeats them instead of stepping.
        "repeated": _json("/world/repeated", "franka_sim/RepeatedCycles", _object(
            first=_INT, last=_INT)),
        # Cycles that went by with no state (lockstep rounds an idle gap up to whole
        # IDLE_QUANTUM cycles): replay moves the clock on over them.
        "skipped": _json("/world/skipped", "franka_sim/SkippedCycles", _object(
            first=_INT, last=_INT)),
        "log": _json("/log", "franka_sim/LogLine", _object(
            level=_STR, logger=_STR, message=_STR, robot=_STR)),
    }
