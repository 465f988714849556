"""One client's TCP conversation with the robot (sans-IO).

Bytes in, reply bytes out. The session enforces the handshake (Connect first, version 10),
splits frames, and dispatches each decoded request to the robot core. Malformed input raises
`SessionError` — the adapter logs its one-line message and closes the connection, which is the
only rejection the FCI protocol has for a frame it cannot parse.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.enums import ROBOT_VERSION, Command, ConnectStatus
from franka_sim.protocol.framing import FrameReader, ProtocolError, decode_request
from franka_sim.robot.requests import RequestHandler

log = logging.getLogger(__name__)

MAX_MESSAGE_SIZE = 64 * 1024


class SessionError(Exception):
    """The conversation cannot go on; the message says why (one log line)."""


@dataclass
class Handshake:
    """What a successful Connect established."""

    udp_port: int


class RobotSession:
    def __init__(self, handler: RequestHandler) -> None:
        self.handler = handler
        self.handshake: Handshake | None = None
        self.closed = False
        self._reader = FrameReader(msg.CommandHeader, msg.REQUEST_SIZES, MAX_MESSAGE_SIZE)

    def receive(self, data: bytes) -> list[bytes]:
        """Feed received bytes; return the replies to send, in order."""
        if self.closed:
            return []
        try:
            frames = self._reader.feed(data)
        except ProtocolError as exc:
            self.closed = True
            raise SessionError(f"malformed message: {exc}") from exc
        replies: list[bytes] = []
        for frame in frames:
            replies.extend(self._dispatch(frame))
            if self.closed:
                break
        return replies

    def _dispatch(self, frame) -> list[bytes]:
        command = Command(frame.command)
        request = decode_request(frame)
        if self.handshake is None:
            if command is not Command.Connect:
                self.closed = True
                raise SessionError(f"{command.name} sent before Connect")
            return [self._connect(frame.command_id, request)]
        if command is Command.Connect:
            self.closed = True
            raise SessionError("a second Connect on an established session")
        return self.handler.handle(command, frame.command_id, request)

    def _connect(self, command_id: int, request) -> bytes:
        version = int(request.version)
        if version != ROBOT_VERSION:
            log.warning(
                "client speaks robot protocol version %d, we speak %d: rejected",
                version, ROBOT_VERSION,
            )
            self.closed = True
            return msg.build_response(
                Command.Connect, command_id, ConnectStatus.kIncompatibleLibraryVersion,
                version=ROBOT_VERSION,
            )
        self.handshake = Handshake(udp_port=int(request.udp_port))
        return msg.build_response(
            Command.Connect, command_id, ConnectStatus.kSuccess, version=ROBOT_VERSION
        )
