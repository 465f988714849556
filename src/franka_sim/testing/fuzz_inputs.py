"""Hostile inputs for the wire layer and the TCP sessions, written once for two drivers.

Every choice goes through a `Chooser`, so the same generators serve the property tests (a
chooser that draws from hypothesis, which can then shrink a failure to its smallest input) and
`benchmarks/fuzz.py` (a seeded `random.Random`, fast enough for millions of inputs). Inputs are
messages of the right shape with hostile values (NaN, ±inf, huge, unknown enum values), valid
messages in orders the protocol does not allow (Move before Connect, two Connects), mutations
of valid messages (bit flips, truncation, a lying size, another command id), random bytes, and
any of these cut at random points as TCP may deliver them.
"""

from __future__ import annotations

import random
import struct
from dataclasses import dataclass
from typing import Protocol, Sequence, TypeVar

from construct import Array, Enum, Flag, FormatField, Struct

from franka_sim.protocol import gripper_messages as gm
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import vacuum_gripper_messages as vm
from franka_sim.protocol.codec import COMMAND_DTYPE, encode_command
from franka_sim.protocol.message import build_message as message_bytes
from franka_sim.protocol.enums import (GRIPPER_VERSION, ROBOT_VERSION, VACUUM_GRIPPER_VERSION,
                                       Command, GripperCommand, VacuumGripperCommand)
from franka_sim.protocol.robot_command import RobotCommand

T = TypeVar("T")


class Chooser(Protocol):
    """Where every choice comes from: `integer(low, high)` (both included), `raw(max_size)`."""

    def integer(self, low: int, high: int) -> int: ...

    def raw(self, max_size: int) -> bytes: ...


class RandomChooser:
    """Choices from a seeded random.Random (reproducible from the seed)."""

    def __init__(self, seed: int) -> None:
        self._random = random.Random(seed)

    def integer(self, low: int, high: int) -> int:
        return self._random.randint(low, high)

    def raw(self, max_size: int) -> bytes:
        return self._random.randbytes(self._random.randint(0, max_size))


def pick(c: Chooser, options: Sequence[T]) -> T:
    return options[c.integer(0, len(options) - 1)]


@dataclass(frozen=True)
class Wire:
    """One TCP protocol as the generators see it: header layout, commands, request structs."""

    name: str
    header: Struct
    size_offset: int  # where the header's uint32 size field starts
    command_format: str  # the header's command field
    structs: dict
    connect: int
    version: int
    responses: dict  # the response structs by command


ROBOT_WIRE = Wire("robot", rm.CommandHeader, 8, "<I", rm.REQUEST_STRUCTS, Command.Connect,
                  ROBOT_VERSION, rm.RESPONSE_STRUCTS)
GRIPPER_WIRE = Wire("gripper", gm.GripperHeader, 6, "<H", gm.GRIPPER_REQUEST_STRUCTS,
                    GripperCommand.Connect, GRIPPER_VERSION, gm.GRIPPER_RESPONSE_STRUCTS)
VACUUM_GRIPPER_WIRE = Wire("vacuum_gripper", vm.VacuumGripperHeader, 6, "<H",
                           vm.VACUUM_GRIPPER_REQUEST_STRUCTS, VacuumGripperCommand.Connect,
                           VACUUM_GRIPPER_VERSION, vm.VACUUM_GRIPPER_RESPONSE_STRUCTS)

# Doubles that break naive code: signed zero, the extremes, the non-finite.
_SPECIAL_FLOATS = (0.0, -0.0, 1.0, -1.0, 0.5, 1e-300, 5e-324, 1e300, -1e300,
                   1.7976931348623157e308, float("inf"), float("-inf"), float("nan"))


def real(c: Chooser) -> float:
    """A double: often special, otherwise plain in [-10, 10]."""
    k = c.integer(0, 2 * len(_SPECIAL_FLOATS))
    if k < len(_SPECIAL_FLOATS):
        return _SPECIAL_FLOATS[k]
    return c.integer(-10_000_000, 10_000_000) / 1_000_000


def _unsigned(c: Chooser, size: int, known: Sequence[int] = ()) -> int:
    """An unsigned field: a known value, a small one, or anything that fits."""
    k = c.integer(0, 3)
    if k < 2 and known:
        return pick(c, known)
    if k < 3:
        return c.integer(0, min(16, (1 << 8 * size) - 1))
    return c.integer(0, (1 << 8 * size) - 1)


def field_bytes(c: Chooser, con) -> bytes:
    """Bytes for one declared field (walks the construct declaration)."""
    if isinstance(con, Struct):
        return b"".join(field_bytes(c, sub.subcon) for sub in con.subcons)
    if isinstance(con, Array):
        return b"".join(field_bytes(c, con.subcon) for _ in range(con.count))
    if isinstance(con, Enum):
        size = con.subcon.sizeof()
        known = sorted(int(v) for v in con.decmapping)
        return _unsigned(c, size, known).to_bytes(size, "little")
    if isinstance(con, FormatField) and con.fmtstr[-1] == "d":
        return struct.pack("<d", real(c))
    if isinstance(con, FormatField):
        size = con.sizeof()
        return _unsigned(c, size).to_bytes(size, "little")
    if isinstance(con, type(Flag)):  # 0, 1 or any other byte (read as true)
        return bytes([_unsigned(c, 1, (0, 1))])
    raise TypeError(f"no generator for {con!r}")


def request(c: Chooser, wire: Wire, command: int, command_id: int | None = None) -> bytes:
    """A well-framed request of `command` whose payload values are all chosen (often hostile)."""
    struct_ = wire.structs[command]
    payload = b"".join(field_bytes(c, sub.subcon) for sub in struct_.subcons[1:])
    if command == wire.connect and c.integer(0, 3):
        payload = struct.pack("<HH", wire.version, c.integer(0, 65535))  # the right version
    size = wire.header.sizeof() + len(payload)
    if command_id is None:
        command_id = _unsigned(c, 4)
    header = struct.pack(wire.command_format, command) + struct.pack("<II", command_id, size)
    return header + payload


_IDENTITY = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0]
_DEVIATION = {"translation": 10.0, "rotation": 3.12, "elbow": 6.283185307179586}


def _move(controller: int, generator: int) -> dict:
    return dict(controller_mode=controller, motion_generator_mode=generator,
                maximum_path_deviation=_DEVIATION, maximum_goal_pose_deviation=_DEVIATION,
                use_async_motion_generator=False, maximum_velocity=[0.0] * 7)


# Requests with the values libfranka sends by default: what gets past validation, so the
# state machines behind it (motions, errors, recovery, the Hand's actions) are reached too.
_TYPICAL_FIELDS = {
    "robot": [
        (Command.Connect, dict(version=ROBOT_VERSION, udp_port=40000)),
        *[(Command.Move, _move(2, generator)) for generator in range(5)],
        *[(Command.Move, _move(controller, generator))
          for controller in (0, 1) for generator in range(4)],
        (Command.StopMove, {}),
        (Command.SetCollisionBehavior, {
            **{f"{b}_torque_thresholds_{k}": [20.0] * 7 for b in ("lower", "upper")
               for k in ("acceleration", "nominal")},
            **{f"{b}_force_thresholds_{k}": [20.0] * 6 for b in ("lower", "upper")
               for k in ("acceleration", "nominal")}}),
        (Command.SetJointImpedance, dict(K_theta=[3000.0] * 4 + [2500.0] * 3)),
        (Command.SetCartesianImpedance, dict(K_x=[3000.0] * 3 + [300.0] * 3)),
        (Command.SetGuidingMode, dict(guiding_mode=[True] * 6, nullspace=False)),
        (Command.SetEEToK, dict(EE_T_K=_IDENTITY)),
        (Command.SetNEToEE, dict(NE_T_EE=_IDENTITY)),
        (Command.SetLoad, dict(m_load=0.5, F_x_Cload=[0.0, 0.0, 0.05], I_load=[0.001] * 9)),
        (Command.AutomaticErrorRecovery, {}),
        (Command.GetRobotModel, {}),
    ],
    "gripper": [
        (GripperCommand.Connect, dict(version=GRIPPER_VERSION, udp_port=40001)),
        (GripperCommand.Homing, {}),
        (GripperCommand.Move, dict(width=0.04, speed=0.1)),
        (GripperCommand.Grasp, dict(width=0.02, epsilon_inner=0.005, epsilon_outer=0.005,
                                    speed=0.1, force=20.0)),
        (GripperCommand.Stop, {}),
    ],
    "vacuum_gripper": [
        (VacuumGripperCommand.Connect, dict(version=VACUUM_GRIPPER_VERSION, udp_port=40002)),
        (VacuumGripperCommand.Vacuum, dict(vacuum=100, profile=0, timeout=1000)),
        (VacuumGripperCommand.DropOff, dict(timeout=1000)),
        (VacuumGripperCommand.Stop, {}),
    ],
}


def typical(c: Chooser, wire: Wire) -> bytes:
    """A request as libfranka sends it (defaults), with a chosen command id."""
    command, fields = pick(c, _TYPICAL_FIELDS[wire.name])
    structure = wire.structs[command]
    return message_bytes(structure, command, _unsigned(c, 4), fields)


def mutate(c: Chooser, wire: Wire, data: bytes) -> bytes:
    """One to three mutations: a bit flipped, cut short, a lying size, another command id,
    bytes inserted or appended."""
    for _ in range(c.integer(1, 3)):
        kind = c.integer(0, 5)
        if kind == 0 and data:
            bit = c.integer(0, 8 * len(data) - 1)
            data = data[:bit // 8] + bytes([data[bit // 8] ^ (1 << bit % 8)]) + data[bit // 8 + 1:]
        elif kind == 1:
            data = data[:c.integer(0, len(data))]
        elif kind == 2 and len(data) >= wire.size_offset + 4:
            size = pick(c, (0, 1, wire.header.sizeof(), len(data) - 1, len(data) + 1,
                            1 << 16, 1 << 31, (1 << 32) - 1, c.integer(0, 1024)))
            data = data[:wire.size_offset] + struct.pack("<I", size) + data[wire.size_offset + 4:]
        elif kind == 3:
            width = struct.calcsize(wire.command_format)
            command = _unsigned(c, width, range(len(wire.structs) + 2))
            data = struct.pack(wire.command_format, command) + data[width:]
        elif kind == 4:
            at = c.integer(0, len(data))
            data = data[:at] + c.raw(16) + data[at:]
        else:
            data = data + c.raw(32)
    return data


def message(c: Chooser, wire: Wire) -> bytes:
    """One TCP message: mostly well-framed with chosen values, else mutated, else noise."""
    k = c.integer(0, 11)
    if k < 5:
        return typical(c, wire)
    if k < 8:
        return request(c, wire, pick(c, list(wire.structs)))
    if k < 11:
        return mutate(c, wire, typical(c, wire))
    return c.raw(64)


def conversation(c: Chooser, wire: Wire, max_messages: int = 6) -> list[bytes]:
    """What one client sends on TCP, as the chunks recv hands over: usually a valid Connect
    first, then messages in any order (a second Connect, Move at once, requests after a
    malformed one), the whole stream cut at random points."""
    messages = []
    if c.integer(0, 4):
        messages.append(request(c, wire, wire.connect))
    messages += [message(c, wire) for _ in range(c.integer(0, max_messages))]
    return chunks(c, b"".join(messages))


def chunks(c: Chooser, stream: bytes) -> list[bytes]:
    """`stream` cut as recv might return it: whole, or at a few random points."""
    cuts = sorted({c.integer(1, max(1, len(stream) - 1)) for _ in range(c.integer(0, 4))})
    bounds = [0, *[x for x in cuts if x < len(stream)], len(stream)]
    return [stream[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]


def robot_command(c: Chooser, message_id: int | None = None) -> bytes:
    """A RobotCommand datagram: the right size with chosen (often non-finite) values, or the
    wrong size."""
    k = c.integer(0, 7)
    if k == 0:
        return c.raw(COMMAND_DTYPE.itemsize + 8)
    if k < 4:  # a torque loop's answer: small torques, sometimes the last one
        data = encode_command(tau_J_d=[c.integer(-1000, 1000) / 1000 for _ in range(7)],
                              torque_command_finished=not c.integer(0, 20))
    else:
        data = field_bytes(c, RobotCommand)
    if message_id is not None and c.integer(0, 3):
        data = struct.pack("<Q", message_id) + data[8:]
    return data

