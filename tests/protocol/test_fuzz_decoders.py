"""Every decoder of the wire layer against hostile bytes: only the protocol's own rejections
(ProtocolError) come out, and what is accepted is whole and well-formed."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st
from support.fuzzing import FUZZ, DrawChooser

from franka_sim.protocol.codec import COMMAND_DTYPE
from franka_sim.robot.session import GRIPPER, ROBOT, VACUUM_GRIPPER
from franka_sim.testing.fuzz_inputs import (
    GRIPPER_WIRE,
    VACUUM_GRIPPER_WIRE,
    ROBOT_WIRE,
    chunks,
    message,
    robot_command,
)
from franka_sim.testing.fuzz_targets import check_datagram, check_frame_reader

SERVICES = {"robot": (ROBOT, ROBOT_WIRE), "gripper": (GRIPPER, GRIPPER_WIRE),
            "vacuum_gripper": (VACUUM_GRIPPER, VACUUM_GRIPPER_WIRE)}


@FUZZ
@given(st.data(), st.sampled_from(sorted(SERVICES)))
def test_frame_reader_takes_any_stream_of_messages(data, name):
    service, wire = SERVICES[name]
    c = DrawChooser(data)
    stream = b"".join(message(c, wire) for _ in range(c.integer(1, 6)))
    check_frame_reader(service, chunks(c, stream))


@FUZZ
@given(st.lists(st.binary(max_size=80), max_size=6), st.sampled_from(sorted(SERVICES)))
def test_frame_reader_takes_random_bytes(stream, name):
    check_frame_reader(SERVICES[name][0], stream)


@FUZZ
@given(st.data())
def test_robot_command_decoder(data):
    check_datagram(robot_command(DrawChooser(data)))


@FUZZ
@given(st.binary(max_size=1400))
def test_datagram_decoders_take_random_bytes(datagram):
    check_datagram(datagram)


@FUZZ
@given(st.binary(min_size=COMMAND_DTYPE.itemsize, max_size=COMMAND_DTYPE.itemsize))
def test_any_robot_command_of_the_right_size_decodes(datagram):
    check_datagram(datagram)
