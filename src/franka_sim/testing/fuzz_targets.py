"""What fuzzed input is fed to, and what must hold afterwards (see fuzz_inputs.py).

Each check raises on a broken invariant (AssertionError) or lets an unexpected exception escape:
either is a crash. The rejections the protocol allows are not: a decoder's `ProtocolError`, a
session's `SessionError` (the server logs it and closes that connection). The session targets
wire the real pieces as the server does (server/sim.py), minus the sockets and threads: a
session over a ArmCore stepped by MuJoCo, or over the Hand or the vacuum gripper.
"""

from __future__ import annotations

import math
import struct

import numpy as np
from construct import Container, EnumInteger

from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.protocol.codec import (
    STATE_DTYPE,
    decode_command,
    decode_gripper_state,
    decode_state,
    command_fields_out,
    non_finite_command_fields,
)
from franka_sim.protocol.enums import (ConnectStatus, GripperConnectStatus, RobotMode,
                                       VacuumGripperConnectStatus)
from franka_sim.protocol.exceptions import DatagramSizeError, ProtocolError
from franka_sim.protocol.framing import FrameReader, decode_request
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.arm_cycle import ArmCycle
from franka_sim.physics.fingers import FINGERS
from franka_sim.robot.hand import Hand
from franka_sim.robot.session import GRIPPER, ROBOT, VACUUM_GRIPPER, Service, Session, SessionError
from franka_sim.robot.vacuum_gripper import VacuumGripper
from franka_sim.physics.suction import CUP, MAX_VACUUM
from franka_sim.protocol.vacuum_gripper_messages import decode_vacuum_gripper_state
from franka_sim.testing.fuzz_inputs import (
    GRIPPER_WIRE,
    ROBOT_WIRE,
    VACUUM_GRIPPER_WIRE,
    Chooser,
    Wire,
    conversation,
    robot_command,
)

_ROBOT_MODES = {int(m) for m in RobotMode}
_RANGE = 1e6  # a bound to check command_fields_out against
_FLOAT_FIELDS = tuple(name for name, (dtype, _) in STATE_DTYPE.fields.items()
                      if dtype.base.kind == "f")
_URDF = default_urdf_text()
_DESCRIPTION = load_arm_description(_URDF)
# The vacuum gripper's lip 1 mm into the default cube's top (examples/pick_and_place.py's IK).
_CUP_ON_CUBE = (0.0, 0.322358, 0.0, -2.544335, 0.0, 2.866692, 0.785398)


def check_frame_reader(service: Service, stream: list[bytes]) -> None:
    """A FrameReader cuts only whole, known, fixed-size frames, each of which decodes; it never
    holds back more than the largest request; once it rejected a header it stays failed."""
    reader = FrameReader(service.header, service.request_sizes, service.max_size)
    largest = max(service.request_sizes.values())
    failed: ProtocolError | None = None
    for data in stream:
        try:
            frames = reader.feed(data)
        except ProtocolError as exc:
            assert failed is None or exc is failed, "a failed reader raised another error"
            failed = exc
            continue
        assert failed is None, "a failed reader accepted more bytes"
        for frame in frames:
            assert len(frame.data) == service.request_sizes[frame.command]
            decode_request(frame, service.request_structs)
        assert reader.buffered < largest, f"{reader.buffered} bytes held back"


def check_datagram(data: bytes) -> None:
    """The UDP decoders take exactly their size and reject any other with DatagramSizeError."""
    for decode, size in ((decode_command, 371), (decode_state, 1377), (decode_gripper_state, 23)):
        try:
            record = decode(data)
        except DatagramSizeError:
            assert len(data) != size
            continue
        assert len(data) == size
        if decode is decode_command:
            bad = non_finite_command_fields(record)
            finite = all(np.isfinite(record[n]).all() for n in record.dtype.names)
            assert bool(bad) != finite, bad
            assert command_fields_out(record, _RANGE)[0] == bad
            if finite:
                beyond = command_fields_out(record, _RANGE)[1]
                assert beyond == [n for n in record.dtype.names
                                  if record.dtype[n].base.kind == "f"
                                  and (np.abs(record[n]) > _RANGE).any()], beyond


def check_reply(wire: Wire, reply: bytes) -> Container:
    """A reply is one whole response of a known command whose status its enum defines."""
    header = wire.header.parse(reply)
    assert header.size == len(reply), (header.size, len(reply))
    parsed = wire.responses[int(header.command)].parse(reply)
    assert not isinstance(parsed.status, EnumInteger), f"status {parsed.status}"
    return parsed


class _Target:
    """A session over a service's real state machine, and the cycles that clock it."""

    wire: Wire
    service: Service

    def __init__(self, enforce_motion_limits: bool = True) -> None:
        # Enforced, a command beyond the FR3's limits ends in a reflex, as on the robot. Log-only
        # (the server's default) applies it, and the motors saturate (physics/arm.py): the
        # physics stays stable under either.
        self.core = ArmCore(_DESCRIPTION, np.array(READY_POSE), urdf=_URDF.encode(),
                              enforce_motion_limits=enforce_motion_limits)
        self.cycle = ArmCycle(self.core, self._backend(), self._hand())
        self.session: Session | None = None
        self.replies: list[bytes] = []
        self.step()

    def _backend(self) -> MujocoBackend:
        return MujocoBackend(_DESCRIPTION, np.array(READY_POSE))

    def _hand(self) -> Hand | None:
        return None

    def open(self) -> None:
        self.session = self._session()
        self.replies = []

    def tcp(self, data: bytes) -> None:
        """Bytes from the client; a closed session gets no more (the server closed it)."""
        session = self.session
        if session is None or session.closed:
            return
        connected = session.handshake is not None
        try:
            replies = session.feed(data)
        except SessionError:
            assert session.closed, "a SessionError left the session open"
            replies = []
        for reply in replies:
            parsed = check_reply(self.wire, reply)
            if int(parsed.header.command) == self.wire.connect:  # ours, or one we serve too
                assert parsed.version == self.wire.version or (
                    parsed.status == self._success and parsed.version in self.service.dialects)
        self.replies += replies
        if not connected and session.handshake is not None:
            self._connected()

    def close(self) -> None:
        """The client is gone (or the server closed it): what the endpoint's disconnect does."""
        if self.session is not None:
            self.session = None
            self._gone()

    def step(self, n: int = 1) -> None:
        """Cycles: every state packs, decodes and says something legal."""
        for _ in range(n):
            before = self.core.message_id
            released = self.cycle.release()
            assert released.state is not None, "the cycle could not pack its state"
            state = decode_state(released.state)
            assert int(state["message_id"]) == before + 1
            assert int(state["robot_mode"]) in _ROBOT_MODES, int(state["robot_mode"])
            for name in _FLOAT_FIELDS:  # no command, however absurd, publishes inf or NaN
                assert np.isfinite(state[name]).all(), f"{name} is not finite"
            warnings = self.cycle.physics.data.warning
            assert not any(w.number for w in warnings), "the physics went unstable"
            replies = self.cycle.complete(released)
            for reply in replies.robot:
                check_reply(ROBOT_WIRE, reply)
            for tool_replies, tool_state in replies.tools:
                for reply in tool_replies:
                    check_reply(self.wire, reply)
                if tool_state is not None:
                    self._check_tool_state(tool_state)

    def still_serves(self) -> None:
        """After anything, the next client is welcome: its Connect succeeds."""
        session = self._session()
        (reply,) = session.feed(_connect(self.wire))
        assert check_reply(self.wire, reply).status == self._success, "Connect refused"


class RobotTarget(_Target):
    """Port 1337: a Session over a ArmCore, stepped by MuJoCo."""

    wire, service, _success = ROBOT_WIRE, ROBOT, ConnectStatus.kSuccess.name

    def _session(self) -> Session:
        return Session(ROBOT, self.core.handle)

    def _connected(self) -> None:
        self.core.client_connected()

    def _gone(self) -> None:
        self.core.client_gone()

    def udp(self, data: bytes, echo_state: bool) -> None:
        """A RobotCommand datagram; `echo_state`: its message_id answers the open cycle."""
        if echo_state and len(data) == 371:
            data = struct.pack("<Q", self.core.message_id) + data[8:]
        try:
            command = decode_command(data)
        except DatagramSizeError:
            return
        self.cycle.receive(command)


class GripperTarget(_Target):
    """Port 1338: a Session over the Hand, its fingers stepped by MuJoCo."""

    wire, service, _success = GRIPPER_WIRE, GRIPPER, GripperConnectStatus.kSuccess.name

    def _backend(self) -> MujocoBackend:
        return MujocoBackend(_DESCRIPTION, np.array(READY_POSE), scene_xml=default_scene_path(),
                             tool=FINGERS)

    def _hand(self) -> Hand:
        self.hand = Hand()
        return self.hand

    def _session(self) -> Session:
        return Session(GRIPPER, self.hand.request)

    def _connected(self) -> None:
        pass

    def _gone(self) -> None:
        self.hand.client_gone()

    def _check_tool_state(self, data: bytes) -> None:
        width = float(decode_gripper_state(data)["width"])
        assert math.isfinite(width), width


class VacuumGripperTarget(GripperTarget):
    """Port 1339: a Session over the vacuum gripper, its cup on the cube, stepped by MuJoCo."""

    wire, service = VACUUM_GRIPPER_WIRE, VACUUM_GRIPPER
    _success = VacuumGripperConnectStatus.kSuccess.name

    def _backend(self) -> MujocoBackend:
        return MujocoBackend(_DESCRIPTION, np.array(_CUP_ON_CUBE),
                             scene_xml=default_scene_path(), tool=CUP)

    def _hand(self) -> VacuumGripper:
        self.hand = VacuumGripper()
        return self.hand

    def _session(self) -> Session:
        return Session(VACUUM_GRIPPER, self.hand.request)

    def _check_tool_state(self, data: bytes) -> None:
        state = decode_vacuum_gripper_state(data)
        assert 0 <= state.vacuum <= MAX_VACUUM and state.actual_power in (0, 100), state
        assert not isinstance(state.device_status, EnumInteger), state.device_status


def _connect(wire: Wire) -> bytes:
    version = struct.pack("<HH", wire.version, 4242)
    header = wire.header.sizeof() + len(version)
    return struct.pack(wire.command_format, wire.connect) + struct.pack("<II", 1, header) + version



def fuzz_session(c: Chooser, target: _Target) -> None:
    """One client's conversation, with cycles (and for the robot, RobotCommands) in between,
    then its disconnect; the next client must still be served."""
    target.open()
    for data in conversation(c, target.wire):
        target.tcp(data)
        if isinstance(target, RobotTarget):
            for _ in range(c.integer(0, 2)):
                target.udp(robot_command(c), echo_state=c.integer(0, 3) > 0)
        target.step(c.integer(0, 3))
    target.close()
    target.step(c.integer(1, 5))
    target.still_serves()
