"""Hot-path codec for the UDP datagrams, derived from the construct declarations.

construct is the schema but needs a few hundred microseconds to build one RobotState, a large
share of the 1 ms cycle. A numpy structured dtype with the same packed layout encodes or decodes
in under a microsecond. The dtypes below are *generated* by walking the construct structs, never
written by hand, so the schema stays the one place where the layout is defined; tests check that
both give identical bytes.
"""

import sys
from typing import Any

import numpy as np
from construct import Array, Construct, Enum, Flag, FormatField, Struct

from franka_sim.kernels import doubles_within

from .exceptions import DatagramSizeError
from .gripper_messages import GripperState
from .vacuum_gripper_messages import VacuumGripperState
from .robot_command import RobotCommand
from .robot_state import RobotState

# struct-module format letter -> numpy kind; the width comes from the field's own size, because
# some letters ('l', 'L') mean 4 bytes to struct but 8 bytes to numpy.
_KIND = {"b": "i", "h": "i", "i": "i", "l": "i", "q": "i"}
_KIND |= {k.upper(): "u" for k in _KIND} | {"e": "f", "f": "f", "d": "f"}


def _field_dtype(con: Construct) -> np.dtype:
    if isinstance(con, Array):
        return np.dtype((_field_dtype(con.subcon), (con.count,)))
    if isinstance(con, Struct):
        return dtype_from_struct(con)
    if isinstance(con, type(Flag)):  # construct's Flag is a singleton instance
        return np.dtype(np.bool_)  # assigning any truthy value stores 1, like construct
    if isinstance(con, Enum):  # the wire carries the underlying integer
        return _field_dtype(con.subcon)
    if isinstance(con, FormatField):
        if con.fmtstr[0] != "<" and con.sizeof() > 1:
            raise TypeError(f"only little-endian fields are supported, got {con.fmtstr}")
        return np.dtype(f"<{_KIND[con.fmtstr[-1]]}{con.sizeof()}")
    raise TypeError(f"no numpy equivalent for {con!r}")


def dtype_from_struct(struct: Struct) -> np.dtype:
    """Packed numpy dtype with the same field names, order and bytes as ``struct``."""
    fields = [(sub.name, _field_dtype(sub.subcon)) for sub in struct.subcons]
    dtype = np.dtype(fields)  # no align=True: the protocol is packed
    assert dtype.itemsize == struct.sizeof(), (dtype.itemsize, struct.sizeof())
    return dtype


STATE_DTYPE = dtype_from_struct(RobotState)
COMMAND_DTYPE = dtype_from_struct(RobotCommand)
GRIPPER_STATE_DTYPE = dtype_from_struct(GripperState)
VACUUM_GRIPPER_STATE_DTYPE = dtype_from_struct(VacuumGripperState)


class RecordBuffer:
    """One preallocated record whose fields are persistent, writable numpy views.

    Attributes are named like the fields: ``buf.q[:] = q``, ``buf.message_id[...] = n``. The
    views stay valid for the buffer's life, so a publisher fills only what changed each cycle
    and packs without allocating field objects.
    """

    def __init__(self, dtype: np.dtype) -> None:
        self.record = np.zeros((), dtype)
        for name in dtype.names:
            setattr(self, name, self.record[name])

    def matrix(self, name: str, shape: tuple[int, int]) -> np.ndarray:
        """A column-major matrix field as a writable (rows, cols) view: a matrix is written
        into it as is, without a reordered copy first."""
        rows, cols = shape
        return getattr(self, name).reshape(cols, rows).T

    def span(self, first: str, last: str) -> np.ndarray:
        """Adjacent fields of one element type, first to last, as one flat writable view
        (e.g. to write a few floats item by item without a field lookup each)."""
        fields = self.record.dtype.fields
        start, end = fields[first][1], fields[last][1] + fields[last][0].itemsize
        base = fields[first][0].base
        assert all(fields[n][0].base == base for n in self.record.dtype.names
                   if start <= fields[n][1] < end), (first, last)
        raw = self.record.reshape(1).view(np.uint8)
        return raw[start:end].view(base)

    def pack(self) -> bytes:
        """A copy of the record's bytes (a copy, so the next cycle may overwrite the buffer)."""
        return self.record.tobytes()


class StateBuffer(RecordBuffer):
    """The RobotState being prepared for the next cycle (1377 bytes when packed)."""

    def __init__(self) -> None:
        super().__init__(STATE_DTYPE)


class GripperStateBuffer(RecordBuffer):
    """The GripperState being prepared for the next datagram (23 bytes when packed)."""

    def __init__(self) -> None:
        super().__init__(GRIPPER_STATE_DTYPE)


def _decode(data: bytes, dtype: np.dtype, what: str) -> np.void:
    # No copy: the record shares memory with ``data``. asyncio hands datagrams over as
    # immutable bytes, which makes that safe; a caller reusing a bytearray must copy first.
    if len(data) != dtype.itemsize:
        raise DatagramSizeError(f"{what} must be {dtype.itemsize} bytes, got {len(data)}")
    return np.frombuffer(data, dtype)[0]


def _encode(dtype: np.dtype, fields: dict[str, Any]) -> bytes:
    record = np.zeros((), dtype)
    for name, value in fields.items():
        record[name] = value
    return record.tobytes()


def decode_command(data: bytes) -> np.void:
    """Read-only view of a RobotCommand datagram: ``rec["q_c"]``, ``rec["message_id"]``, ..."""
    return _decode(data, COMMAND_DTYPE, "RobotCommand")


def _float64_runs(dtype: np.dtype) -> list[tuple[int, int, tuple[str, ...]]]:
    """Contiguous runs of float64 fields: (byte offset, count, field names) — derived, not typed."""
    runs: list[tuple[int, int, tuple[str, ...]]] = []
    for name in dtype.names:
        field, offset = dtype.fields[name][:2]
        base = field.base if field.subdtype else field
        if base != np.dtype("<f8"):
            continue
        count = field.itemsize // 8
        if runs and runs[-1][0] + 8 * runs[-1][1] == offset:
            start, n, names = runs[-1]
            runs[-1] = (start, n + count, names + (name,))
        else:
            runs.append((offset, count, (name,)))
    return runs


_COMMAND_FLOAT_RUNS = _float64_runs(COMMAND_DTYPE)
_COMMAND_RUNS = tuple((offset, count) for offset, count, _ in _COMMAND_FLOAT_RUNS)
_LARGEST = sys.float_info.max  # within ±_LARGEST: finite


def non_finite_command_fields(record: np.void) -> list[str]:
    """Names of RobotCommand fields holding NaN or ±inf ([] for a usable command); the common
    case is one look at every double (kernels.doubles_within)."""
    if doubles_within(record, _COMMAND_RUNS, _LARGEST):
        return []
    return _non_finite(record)


def _non_finite(record: np.void) -> list[str]:
    return [n for _, _, names in _COMMAND_FLOAT_RUNS for n in names
            if not np.isfinite(record[n]).all()]


def command_fields_out(record: np.void, bound: float) -> tuple[list[str], list[str]]:
    """(fields holding NaN or ±inf, finite fields holding a value beyond ±bound) of a
    RobotCommand; one look at its doubles when both are empty (kernels.doubles_within)."""
    if doubles_within(record, _COMMAND_RUNS, bound):
        return [], []
    if bad := _non_finite(record):
        return bad, []
    return [], [n for _, _, names in _COMMAND_FLOAT_RUNS for n in names
                if (np.abs(record[n]) > bound).any()]


def clipped_command(record: np.void, bound: float) -> np.void:
    """A copy of the RobotCommand with every double clipped to ±bound."""
    copy = np.frombuffer(bytearray(record.tobytes()), COMMAND_DTYPE)[0]
    for _, _, names in _COMMAND_FLOAT_RUNS:
        for name in names:
            np.clip(copy[name], -bound, bound, out=copy[name])
    return copy


def encode_command(**fields: Any) -> bytes:
    """RobotCommand bytes with the given fields set and the rest zero, as libfranka sends."""
    return _encode(COMMAND_DTYPE, fields)


def decode_state(data: bytes) -> np.void:
    """Read-only view of a RobotState datagram (for tests and Python clients)."""
    return _decode(data, STATE_DTYPE, "RobotState")


def pack_gripper_state(**fields: Any) -> bytes:
    """GripperState bytes with the given fields set and the rest zero."""
    return _encode(GRIPPER_STATE_DTYPE, fields)


def decode_gripper_state(data: bytes) -> np.void:
    """Read-only view of a GripperState datagram."""
    return _decode(data, GRIPPER_STATE_DTYPE, "GripperState")
