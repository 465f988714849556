"""The numpy hot-path codec produces exactly the bytes of the construct declarations."""

import math

import numpy as np
import pytest
from construct import Array, Float64b, GreedyBytes, Struct

from franka_sim.protocol import (
    COMMAND_DTYPE,
    GRIPPER_STATE_DTYPE,
    STATE_DTYPE,
    DatagramSizeError,
    GripperState,
    GripperStateBuffer,
    ProtocolError,
    RobotCommand,
    RobotState,
    StateBuffer,
    decode_command,
    decode_gripper_state,
    decode_state,
    dtype_from_struct,
    encode_command,
    pack_gripper_state,
)

SPECIAL_FLOATS = [math.nan, math.inf, -math.inf, -0.0]


def random_values(dtype, rng):
    """Field values for ``dtype`` as plain Python objects that construct can build."""
    values = {}
    for name in dtype.names:
        base, shape = dtype[name].base, dtype[name].shape
        count = int(np.prod(shape)) if shape else 1
        if base.kind == "f":
            items = rng.standard_normal(count).astype(base)
            items[rng.random(count) < 0.1] = rng.choice(SPECIAL_FLOATS)
            items = [float(x) for x in items]
        elif base.kind == "b":
            items = [bool(x) for x in rng.random(count) < 0.5]
        else:
            items = [int(x) for x in rng.integers(0, np.iinfo(base).max, count, dtype=base)]
        values[name] = items if shape else items[0]
    return values


def fill(buf, values):
    for name, value in values.items():
        getattr(buf, name)[...] = value


def test_dtypes_mirror_the_construct_structs():
    for dtype, struct, size in [
        (STATE_DTYPE, RobotState, 1377), (COMMAND_DTYPE, RobotCommand, 371),
        (GRIPPER_STATE_DTYPE, GripperState, 23),
    ]:
        assert dtype.itemsize == struct.sizeof() == size
        assert list(dtype.names) == [sub.name for sub in struct.subcons]
    assert STATE_DTYPE["accelerometer_top"].shape == (18,)
    assert STATE_DTYPE["robot_mode"] == np.uint8
    assert COMMAND_DTYPE["valid_elbow"] == np.bool_


@pytest.mark.parametrize("seed", range(20))
def test_state_buffer_packs_like_construct(seed):
    values = random_values(STATE_DTYPE, np.random.default_rng(seed))
    buf = StateBuffer()
    fill(buf, values)
    assert buf.pack() == RobotState.build(values)


def test_state_buffer_fields_are_persistent_views():
    buf = StateBuffer()
    q = buf.q
    buf.q[:] = np.arange(7)
    buf.O_T_EE[:] = np.arange(16.0).reshape(4, 4).ravel(order="F")
    buf.message_id[...] = 99
    buf.robot_mode[...] = 2
    buf.errors[3] = 5  # any truthy value goes out as 1, as construct's Flag would send it
    assert buf.q is q
    state = RobotState.parse(buf.pack())
    assert state.q == list(range(7)) and state.message_id == 99 and state.robot_mode == "kMove"
    assert state.O_T_EE[:4] == [0.0, 4.0, 8.0, 12.0]  # first column of row-major arange
    assert buf.pack()[1290 + 3] == 1
    assert len(buf.pack()) == 1377


@pytest.mark.parametrize("seed", range(20))
def test_decode_command_agrees_with_construct_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    data = bytearray(rng.integers(0, 256, 371, dtype=np.uint8).tobytes())
    # Quiet and signalling NaNs, infinities: the decoder must neither drop nor normalise them.
    for offset, bits in [(8, 0x7FF8000000000001), (64, 0x7FF0000000000001),
                         (120, 0xFFF8000000000000), (314, 0x7FF0000000000000)]:
        data[offset : offset + 8] = bits.to_bytes(8, "little")
    data = bytes(data)
    parsed, record = RobotCommand.parse(data), decode_command(data)
    for name in COMMAND_DTYPE.names:
        if COMMAND_DTYPE[name].base.kind == "f":
            ours = np.asarray(record[name]).tobytes()
            assert np.asarray(parsed[name], dtype="<f8").tobytes() == ours, name
        else:
            assert np.all(record[name] == parsed[name]), name


def test_decoded_command_is_read_only():
    record = decode_command(bytes(371))
    with pytest.raises(ValueError):
        record["q_c"][0] = 1.0


@pytest.mark.parametrize("seed", range(5))
def test_encode_command_builds_like_construct(seed):
    values = random_values(COMMAND_DTYPE, np.random.default_rng(seed))
    assert encode_command(**values) == RobotCommand.build(values)


def test_encode_command_leaves_unset_fields_zero():
    data = encode_command(message_id=7, tau_J_d=np.ones(7), torque_command_finished=True)
    command = RobotCommand.parse(data)
    assert command.message_id == 7 and command.tau_J_d == [1.0] * 7
    assert command.q_c == [0.0] * 7 and command.torque_command_finished is True


def test_decode_state_round_trips_the_state_buffer():
    buf = StateBuffer()
    fill(buf, random_values(STATE_DTYPE, np.random.default_rng(1)))
    assert decode_state(buf.pack()).tobytes() == buf.pack()


@pytest.mark.parametrize("seed", range(5))
def test_gripper_state_packs_like_construct(seed):
    values = random_values(GRIPPER_STATE_DTYPE, np.random.default_rng(seed))
    buf = GripperStateBuffer()
    fill(buf, values)
    assert buf.pack() == GripperState.build(values) == pack_gripper_state(**values)
    assert decode_gripper_state(buf.pack())["message_id"] == values["message_id"]


@pytest.mark.parametrize(
    "decode, size",
    [(decode_command, 371), (decode_state, 1377), (decode_gripper_state, 23)],
)
@pytest.mark.parametrize("delta", [-1, +1])
def test_wrong_datagram_size_raises(decode, size, delta):
    with pytest.raises(DatagramSizeError):
        decode(bytes(size + delta))
    with pytest.raises(ProtocolError):
        decode(b"")


def test_unsupported_construct_types_are_refused():
    with pytest.raises(TypeError):
        dtype_from_struct(Struct("urdf" / GreedyBytes))
    with pytest.raises(TypeError):
        dtype_from_struct(Struct("x" / Array(2, Float64b)))
