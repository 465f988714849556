"""One client's TCP conversation with a service of the robot (sans-IO).

Bytes in, reply bytes out. The robot (port 1337, protocol v10) and the Hand (1338, v3) hold the
same conversation: Connect first with the right version (another version is answered
kIncompatibleLibraryVersion with ours, then the connection closes), frames cut by the shared
FrameReader, every later request handed to the service's handler. Only the wire tables differ,
and they are a `Service`. An older version the service still serves (the robot: v5–v9) is
accepted at Connect, and from then on its Dialect reads the client's requests as the service's
own and writes the service's replies (`wire`) and states (`Handshake.state`) as the client's. Malformed input raises `SessionError` — the adapter logs its one-line
message and closes the connection, which is the only rejection either protocol has for a frame
it cannot parse.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Callable, Mapping

from construct import Struct

from franka_sim.protocol import gripper_messages as gm
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import vacuum_gripper_messages as vm
from franka_sim.protocol.robot_versions import DIALECTS
from franka_sim.protocol.enums import (
    GRIPPER_VERSION,
    ROBOT_VERSION,
    Command,
    ConnectStatus,
    GripperCommand,
    GripperConnectStatus,
    VACUUM_GRIPPER_VERSION,
    VacuumGripperCommand,
    VacuumGripperConnectStatus,
)
from franka_sim.protocol.framing import FrameReader, ProtocolError, decode_request

log = logging.getLogger(__name__)


class SessionError(Exception):
    """The conversation cannot go on; the message says why (one log line)."""


@dataclass
class Handshake:
    """What a successful Connect established: where the client's states go, and (a client of
    an older protocol version) how each state is written for it."""

    udp_port: int
    state: Callable[[bytes], bytes] | None = None
    command: Callable[[bytes], bytes] | None = None  # its RobotCommands as this version's


@dataclass(frozen=True)
class Service:
    """The wire tables of one TCP service: what tells the robot's conversation from the Hand's."""

    name: str  # "robot", "gripper", "vacuum_gripper": names the service in errors and log lines
    version: int
    command: type  # the Command enum (its member Connect opens the conversation)
    connect_status: type
    header: Struct
    request_sizes: dict
    request_structs: dict
    build_response: Callable[..., bytes]
    max_size: int
    # Older protocol versions served too, by version: each a Dialect (protocol/robot_v9.py)
    # that reads its requests as this version's and writes this version's replies as its own.
    dialects: Mapping[int, object] = field(default_factory=dict)


ROBOT = Service("robot", ROBOT_VERSION, Command, ConnectStatus, rm.CommandHeader,
                rm.REQUEST_SIZES, rm.REQUEST_STRUCTS, rm.build_response, 64 * 1024,
                DIALECTS)
GRIPPER = Service("gripper", GRIPPER_VERSION, GripperCommand, GripperConnectStatus,
                  gm.GripperHeader, gm.GRIPPER_REQUEST_SIZES, gm.GRIPPER_REQUEST_STRUCTS,
                  gm.build_gripper_response, 1024)  # the largest gripper request is 50 bytes
VACUUM_GRIPPER = Service("vacuum_gripper", VACUUM_GRIPPER_VERSION, VacuumGripperCommand,
                         VacuumGripperConnectStatus, vm.VacuumGripperHeader,
                         vm.VACUUM_GRIPPER_REQUEST_SIZES, vm.VACUUM_GRIPPER_REQUEST_STRUCTS,
                         vm.build_vacuum_gripper_response, 1024)  # its largest: 20 bytes


class Session:
    """The handshake and framing of one client; `handle(command, command_id, request)` does
    the rest and returns the replies to send now."""

    def __init__(self, service: Service, handle: Callable[..., list[bytes]],
                 library: Callable[[object], bytes | None] | None = None,
                 pairing: "Pairing | None" = None, strict: bool = False) -> None:
        self.service = service
        self.handle = handle
        # The robot kind's own versions, and the one a refusal names (None: the service's);
        # `strict` (--strict-versions): only those are served, else every one the service does.
        self.pairing, self.strict = pairing, strict
        # library(request) → the robot's model library for a LoadModelLibrary (older clients
        # build their Model from it), or None: answered kError.
        self.library = library
        self.handshake: Handshake | None = None
        self.dialect = None  # an older client's (Service.dialects), from its Connect on
        self.closed = False
        self.requests = 0  # frames handled, Connect included
        self._reader = FrameReader(service.header, service.request_sizes, service.max_size)

    @property
    def buffered(self) -> int:
        """Bytes of a message begun but not complete."""
        return self._reader.buffered

    def feed(self, data: bytes) -> list[bytes]:
        """Feed received bytes; return the replies to send, in order."""
        replies: list[bytes] = []
        if self.handshake is None and not self.closed:
            # Until the Connect, one message at a time: the client's version decides whose
            # header and sizes cut the rest (_connect retables the reader).
            replies = self._handle(self._frames(data, most=1))
            data = b""  # (the rest is buffered)
        if self.handshake is None or self.closed:
            return replies
        return replies + self._handle(self._frames(data))

    def _frames(self, data: bytes, most: int | None = None) -> list:
        try:
            return self._reader.feed(data, most=most)
        except ProtocolError as exc:
            self.closed = True
            raise SessionError(f"malformed {self.service.name} message: {exc}") from exc

    def _handle(self, frames: list) -> list[bytes]:
        replies: list[bytes] = []
        for frame in frames:
            self.requests += 1
            replies.extend(self._dispatch(frame))
            if self.closed:
                break
        return replies

    def _dispatch(self, frame) -> list[bytes]:
        service, dialect = self.service, self.dialect
        if dialect is not None:  # an older client: its request as this version names it
            command, request = dialect.request(
                frame.command, decode_request(frame, dialect.request_structs))
        else:
            command = service.command(frame.command)
            request = decode_request(frame, service.request_structs)
        if self.handshake is None:
            if command is not service.command.Connect:
                self.closed = True
                raise SessionError(f"{service.name} {command.name} sent before Connect")
            return [self._connect(frame.command_id, request)]
        if command is service.command.Connect:
            self.closed = True
            raise SessionError(f"a second {service.name} Connect on an established session")
        if not isinstance(command, service.command):  # one this version no longer has
            return [dialect.answer(command, frame.command_id, request, self.library)]
        return list(map(self.wire, self.handle(command, frame.command_id, request)))

    def wire(self, reply: bytes) -> bytes:
        """A reply as this client's protocol version writes it."""
        return reply if self.dialect is None else self.dialect.reply(reply)

    def _connect(self, command_id: int, request) -> bytes:
        service = self.service
        version = int(request.version)
        make_dialect = service.dialects.get(version)
        pairing = self.pairing
        if self.strict and pairing is not None and version not in pairing.versions:
            log.warning("client speaks %s protocol version %d, this %s speaks %s "
                        "(--strict-versions): rejected", service.name, version, pairing.robot,
                        pairing.said)
            return self._incompatible(command_id, pairing.version)
        if version != service.version and make_dialect is None:
            older = f" (and {', '.join(map(str, sorted(service.dialects)))})" \
                if service.dialects else ""
            log.warning("client speaks %s protocol version %d, we speak %d%s: rejected",
                        service.name, version, service.version, older)
            # (A Panda names its own version: the libfranka to use with it, not the newest.)
            return self._incompatible(command_id, service.version if pairing is None
                                      else pairing.version)
        state = command = None
        if make_dialect is not None:
            self.dialect = dialect = make_dialect()
            self._reader.retable(dialect.header, dialect.request_sizes)
            state, command = dialect.state, dialect.command
            log.info("client speaks %s protocol version %d: served as such", service.name,
                     version)
        self.handshake = Handshake(int(request.udp_port), state, command)
        return service.build_response(service.command.Connect, command_id,
                                      service.connect_status.kSuccess, version=version)

    def _incompatible(self, command_id: int, version: int) -> bytes:
        """The robot's refusal, with the version it speaks; then the connection closes."""
        service = self.service
        self.closed = True
        return service.build_response(
            service.command.Connect, command_id,
            service.connect_status.kIncompatibleLibraryVersion, version=version)


@dataclass(frozen=True)
class Pairing:
    """The robot protocol versions a robot kind's own system speaks (--strict-versions): a
    Panda's up to 5 (libfranka 0.9), an FR3's from 6 (0.10) on; `version`, the one its refusal
    names."""

    robot: str
    versions: frozenset
    version: int

    @property
    def said(self) -> str:
        return ", ".join(map(str, sorted(self.versions)))


PAIRINGS = {"fer": Pairing("Panda", frozenset({5}), 5),
            "fr3": Pairing("FR3", frozenset({6, 7, 8, 9, ROBOT_VERSION}), ROBOT_VERSION)}


def robot_session(robot, library: Callable[[object], bytes | None] | None = None,
                  pairing: Pairing | None = None, strict: bool = False) -> Session:
    """The robot's conversation: requests go to the robot (robot/fci.py: an arm or a base);
    `library`: its model library for older clients (model_library/), if it has one;
    `pairing`: its kind's versions (a refusal names its own); `strict`: it accepts those
    alone (else every one served)."""
    return Session(ROBOT, robot.handle, library, pairing, strict)


def tool_session(service: Service, device) -> Session:
    """A tool's conversation (the Hand's: GRIPPER): requests go to its device (robot/tool.py)."""
    return Session(service, device.request)
