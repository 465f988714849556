"""One client's TCP conversation with the Franka Hand (port 1338, protocol v3), sans-IO.

Bytes in, reply bytes out, like the robot's session: Connect first (version 3; another version is
answered kIncompatibleLibraryVersion with ours, then the connection closes), frames cut by the
shared FrameReader, every later request handed to the `Gripper`. Malformed input raises
`SessionError`; the adapter logs its one line and closes the connection.
"""

from __future__ import annotations

import logging

from franka_sim.protocol.enums import GRIPPER_VERSION, GripperCommand, GripperConnectStatus
from franka_sim.protocol.framing import FrameReader, ProtocolError, decode_request
from franka_sim.protocol.gripper_messages import (
    GRIPPER_REQUEST_SIZES,
    GRIPPER_REQUEST_STRUCTS,
    GripperHeader,
    build_gripper_response,
)
from franka_sim.robot.gripper import Gripper
from franka_sim.robot.session import Handshake, SessionError

log = logging.getLogger(__name__)

MAX_MESSAGE_SIZE = 1024  # the largest gripper request is 50 bytes


class GripperSession:
    def __init__(self, gripper: Gripper) -> None:
        self.gripper = gripper
        self.handshake: Handshake | None = None
        self.closed = False
        self._reader = FrameReader(GripperHeader, GRIPPER_REQUEST_SIZES, MAX_MESSAGE_SIZE)

    def receive(self, data: bytes) -> list[bytes]:
        """Feed received bytes; return the replies to send now, in order."""
        if self.closed:
            return []
        try:
            frames = self._reader.feed(data)
        except ProtocolError as exc:
            self.closed = True
            raise SessionError(f"malformed gripper message: {exc}") from exc
        replies: list[bytes] = []
        for frame in frames:
            replies.extend(self._dispatch(frame))
            if self.closed:
                break
        return replies

    def _dispatch(self, frame) -> list[bytes]:
        command = GripperCommand(frame.command)
        request = decode_request(frame, GRIPPER_REQUEST_STRUCTS)
        if self.handshake is None:
            if command is not GripperCommand.Connect:
                self.closed = True
                raise SessionError(f"gripper {command.name} sent before Connect")
            return [self._connect(frame.command_id, request)]
        if command is GripperCommand.Connect:
            self.closed = True
            raise SessionError("a second gripper Connect on an established session")
        return self.gripper.request(command, frame.command_id, request)

    def _connect(self, command_id: int, request) -> bytes:
        version = int(request.version)
        if version != GRIPPER_VERSION:
            log.warning("client speaks gripper protocol version %d, we speak %d: rejected",
                        version, GRIPPER_VERSION)
            self.closed = True
            return build_gripper_response(
                GripperCommand.Connect, command_id,
                GripperConnectStatus.kIncompatibleLibraryVersion, version=GRIPPER_VERSION)
        self.handshake = Handshake(udp_port=int(request.udp_port))
        return build_gripper_response(GripperCommand.Connect, command_id,
                                      GripperConnectStatus.kSuccess, version=GRIPPER_VERSION)
