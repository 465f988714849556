"""A version-9 client's conversation, sans-IO: accepted at Connect and answered as v9, its
requests read as v10's, its replies and states written as v9's, LoadModelLibrary answered with
the library or kError (protocol_specs/robot_v9.md); versions 8 and 7 likewise, 7 without
GetRobotModel."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from franka_sim.description.urdf import default_urdf_text
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import robot_v7, robot_v8
from franka_sim.protocol import robot_v9 as v9
from franka_sim.protocol.codec import STATE_DTYPE
from franka_sim.protocol.enums import Command, MoveStatus
from franka_sim.protocol.message import build_message
from franka_sim.robot.session import ROBOT, Session, SessionError

URDF = default_urdf_text().encode()


class _Robot:
    """What the session hands requests to: records them, answers as the v10 robot would."""

    def __init__(self) -> None:
        self.requests = []

    def handle(self, command, command_id, request):
        self.requests.append((command, request))
        if command is Command.GetRobotModel:
            return [rm.build_response(command, command_id, 0, urdf=URDF)]
        return [rm.build_response(command, command_id, MoveStatus.kMotionStarted)]


def _v9(command: v9.Command, command_id: int, **fields) -> bytes:
    return build_message(v9.REQUEST_STRUCTS[command], command, command_id, fields)


def _connected(library=None, version: int = 9) -> tuple[Session, _Robot]:
    robot = _Robot()
    session = Session(ROBOT, robot.handle, library)
    (reply,) = session.feed(_v9(v9.Command.Connect, 0, version=version, udp_port=4242))
    assert struct.unpack_from("<IIIBH", reply) == (0, 0, 15, 0, version)  # kSuccess
    return session, robot


def test_a_v9_client_is_served_as_v9():
    session, _ = _connected()
    assert isinstance(session.dialect, v9.Dialect)
    assert session.handshake.udp_port == 4242 and session.handshake.state is not None


def test_its_move_reads_as_v10s_without_the_async_generator():
    session, robot = _connected()
    dev = {"translation": 10.0, "rotation": 3.12, "elbow": 6.28}
    (reply,) = session.feed(_v9(v9.Command.Move, 3, controller_mode=0, motion_generator_mode=1,
                                maximum_path_deviation=dev, maximum_goal_pose_deviation=dev))
    command, request = robot.requests[-1]
    assert command is Command.Move
    assert request.use_async_motion_generator is False and request.maximum_velocity == [0.0] * 7
    assert struct.unpack_from("<II", reply) == (1, 3)  # Move is 1 in both


def test_its_get_robot_model_is_id_12_and_the_urdf_has_no_accelerometers():
    session, robot = _connected()
    (reply,) = session.feed(_v9(v9.Command.GetRobotModel, 5))
    assert robot.requests[-1][0] is Command.GetRobotModel
    parsed = rm.GetRobotModelResponse.parse(reply)  # v10's layout, v9's id
    assert int(parsed.header.command) == 12 and parsed.header.size == len(reply)
    assert b"accelerometer" in URDF and b"accelerometer" not in parsed.urdf
    assert b'name="link8"' in parsed.urdf and b'name="joint7"' in parsed.urdf


def test_load_model_library_is_answered_with_the_library_or_k_error():
    asked = []
    session, _ = _connected(library=lambda request: asked.append(request) or b"\x7fELF...")
    (reply,) = session.feed(_v9(v9.Command.LoadModelLibrary, 6, architecture="kX64",
                                system="kLinux"))
    parsed = v9.LoadModelLibraryResponse.parse(reply)
    assert (int(parsed.header.command), parsed.header.command_id) == (11, 6)
    assert parsed.status == "kSuccess" and parsed.library == b"\x7fELF..."
    assert str(asked[0].architecture) == "kX64"
    for library in (None, lambda request: None):
        session, _ = _connected(library=library)
        (reply,) = session.feed(_v9(v9.Command.LoadModelLibrary, 7, architecture="kARM64",
                                    system="kLinux"))
        parsed = v9.LoadModelLibraryResponse.parse(reply)
        assert parsed.status == "kError" and parsed.library == b""


def test_deferred_replies_are_written_as_v9_too():
    """A Move's final status comes later, through the endpoint (Session.wire)."""
    session, _ = _connected()
    final = rm.build_response(Command.Move, 3, MoveStatus.kSuccess)
    assert session.wire(final) == final  # ids 0-10 are v10's
    model = rm.build_response(Command.GetRobotModel, 9, 0, urdf=URDF)
    assert struct.unpack_from("<I", session.wire(model))[0] == 12


def test_its_states_are_the_v10_states_widened():
    dialect = v9.Dialect()
    rng = np.random.default_rng(2)
    state = np.zeros((), STATE_DTYPE)
    for name in STATE_DTYPE.names:
        if STATE_DTYPE[name].base.kind == "f":
            state[name] = rng.normal(size=STATE_DTYPE[name].shape)
    state["message_id"], state["robot_mode"] = 987654321, 2
    state["errors"][3] = state["reflex_reason"][40] = True
    written = v9.RobotState.parse(dialect.state(state.tobytes()))
    for name in STATE_DTYPE.names:
        if name.startswith("accelerometer"):
            assert name not in written
        elif STATE_DTYPE[name].base.kind == "f":
            assert np.array_equal(np.ravel(written[name]), np.ravel(state[name])), name
        else:
            assert np.array_equal(np.ravel(np.asarray(written[name], dtype=int)),
                                  np.ravel(state[name].astype(int))), name


def test_versions_8_and_7_are_served_with_v9s_tables():
    session, robot = _connected(version=8)
    assert isinstance(session.dialect, robot_v8.Dialect)
    (reply,) = session.feed(_v9(v9.Command.GetRobotModel, 5))
    assert struct.unpack_from("<I", reply)[0] == 12
    session, _ = _connected(version=7, library=lambda request: b"lib")
    assert isinstance(session.dialect, robot_v7.Dialect)
    (reply,) = session.feed(_v9(v9.Command.LoadModelLibrary, 6, architecture="kX64",
                                system="kLinux"))
    assert v9.LoadModelLibraryResponse.parse(reply).library == b"lib"
    with pytest.raises(SessionError, match="unknown command 12"):  # v7 has no GetRobotModel
        session.feed(_v9(v9.Command.GetRobotModel, 7))
