"""FrameReader cuts any chunking of a TCP stream into the same messages, and refuses bad headers."""

import random

import pytest

from franka_sim.protocol import (
    GRIPPER_REQUEST_SIZES,
    GRIPPER_REQUEST_STRUCTS,
    MAX_MESSAGE_SIZE,
    REQUEST_SIZES,
    Command,
    CommandHeader,
    Frame,
    FrameReader,
    GripperCommand,
    GripperHeader,
    HeaderSizeTooSmallError,
    MessageSizeMismatchError,
    MessageTooLargeError,
    ProtocolError,
    UnknownCommandError,
    build_gripper_request,
    build_request,
    decode_request,
)

DEVIATION = {"translation": 10.0, "rotation": 3.12, "elbow": 6.28}
ROBOT_MESSAGES = [
    build_request(Command.Connect, 0, version=10, udp_port=50000),
    build_request(Command.GetRobotModel, 1),
    build_request(Command.SetJointImpedance, 2, K_theta=[3000.0] * 7),
    build_request(
        Command.Move, 3, controller_mode=0, motion_generator_mode=0,
        maximum_path_deviation=DEVIATION, maximum_goal_pose_deviation=DEVIATION,
        use_async_motion_generator=False, maximum_velocity=[0.0] * 7,
    ),
    build_request(Command.StopMove, 4),
    build_request(Command.SetGuidingMode, 5, guiding_mode=[True] * 6, nullspace=False),
]
STREAM = b"".join(ROBOT_MESSAGES)
EXPECTED = [Frame(int(CommandHeader.parse(m).command), i, m) for i, m in enumerate(ROBOT_MESSAGES)]


def robot_reader():
    return FrameReader(CommandHeader, REQUEST_SIZES, MAX_MESSAGE_SIZE)


def feed_chunks(reader, stream, cuts):
    frames, last = [], 0
    for cut in [*sorted(cuts), len(stream)]:
        frames += reader.feed(stream[last:cut])
        last = cut
    return frames


def header(command, size, command_id=0):
    return CommandHeader.build({"command": command, "command_id": command_id, "size": size})


def test_whole_stream_in_one_chunk():
    assert robot_reader().feed(STREAM) == EXPECTED


def test_byte_by_byte():
    reader = robot_reader()
    assert feed_chunks(reader, STREAM, range(1, len(STREAM))) == EXPECTED
    assert reader.buffered == 0


def test_every_two_way_split():
    for cut in range(len(STREAM) + 1):
        assert feed_chunks(robot_reader(), STREAM, [cut]) == EXPECTED, cut


@pytest.mark.parametrize("seed", range(50))
def test_random_chunkings(seed):
    rng = random.Random(seed)
    cuts = rng.sample(range(1, len(STREAM)), rng.randint(1, 12))
    assert feed_chunks(robot_reader(), STREAM, cuts) == EXPECTED


def test_partial_message_waits_for_the_rest():
    reader = robot_reader()
    assert reader.feed(ROBOT_MESSAGES[3][:50]) == []
    assert reader.buffered == 50
    assert reader.feed(ROBOT_MESSAGES[3][50:]) == [EXPECTED[3]]


def test_frames_decode_with_their_request_struct():
    move = decode_request(robot_reader().feed(ROBOT_MESSAGES[3])[0])
    assert move.header.command == "Move" and move.maximum_path_deviation.rotation == 3.12
    connect = decode_request(EXPECTED[0])
    assert (connect.version, connect.udp_port) == (10, 50000)
    with pytest.raises(UnknownCommandError):
        decode_request(Frame(99, 0, b""))


def test_gripper_stream():
    messages = [
        build_gripper_request(GripperCommand.Connect, 0, version=3, udp_port=40000),
        build_gripper_request(GripperCommand.Homing, 1),
        build_gripper_request(GripperCommand.Grasp, 2, width=0.02, epsilon_inner=0.005,
                              epsilon_outer=0.005, speed=0.1, force=60.0),
        build_gripper_request(GripperCommand.Move, 3, width=0.08, speed=0.1),
        build_gripper_request(GripperCommand.Stop, 4),
    ]
    stream = b"".join(messages)
    reader = FrameReader(GripperHeader, GRIPPER_REQUEST_SIZES)
    frames = feed_chunks(reader, stream, range(3, len(stream), 7))
    assert [f.command for f in frames] == list(GripperCommand)
    assert [f.data for f in frames] == messages
    grasp = decode_request(frames[2], GRIPPER_REQUEST_STRUCTS)
    assert grasp.force == 60.0 and grasp.header.command == "Grasp"


@pytest.mark.parametrize(
    "bad_header, error",
    [
        (header(Command.StopMove, 11), HeaderSizeTooSmallError),
        (header(Command.StopMove, 0), HeaderSizeTooSmallError),
        (header(99, 5), HeaderSizeTooSmallError),  # size is checked before the command
        (header(Command.Move, MAX_MESSAGE_SIZE + 1), MessageTooLargeError),
        (header(12, 12), UnknownCommandError),  # LoadModelLibrary's old slot is gone in v10
        (header(0xFFFFFFFF, 200), UnknownCommandError),
        (header(Command.Move, 124), MessageSizeMismatchError),
        (header(Command.Connect, 17), MessageSizeMismatchError),
    ],
)
def test_bad_header_is_refused_as_soon_as_it_is_complete(bad_header, error):
    reader = robot_reader()
    assert reader.feed(bad_header[:5]) == []
    with pytest.raises(error) as raised:
        reader.feed(bad_header[5:])  # no payload needed to know it is wrong
    assert isinstance(raised.value, ProtocolError) and isinstance(raised.value, ValueError)


def test_good_frames_before_a_bad_header_are_lost_with_the_connection():
    reader = robot_reader()
    with pytest.raises(MessageSizeMismatchError):
        reader.feed(ROBOT_MESSAGES[0] + header(Command.Move, 124))


def test_reader_stays_failed_after_an_error():
    reader = robot_reader()
    with pytest.raises(UnknownCommandError) as first:
        reader.feed(header(42, 12))
    with pytest.raises(UnknownCommandError) as again:
        reader.feed(ROBOT_MESSAGES[0])
    assert again.value is first.value


def test_gripper_header_errors():
    reader = FrameReader(GripperHeader, GRIPPER_REQUEST_SIZES, max_size=1024)
    too_big = GripperHeader.build({"command": 1, "command_id": 0, "size": 1025})
    with pytest.raises(MessageTooLargeError):
        reader.feed(too_big)
