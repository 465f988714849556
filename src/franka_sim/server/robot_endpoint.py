"""The TCP side of the robot (port 1337): one client at a time, as on the real FCI.

A thin adapter: bytes go to the sans-IO `RobotSession`, replies come back out. A second client
while one is connected is closed with one log line — the FR3 allows a single FCI connection
(docs/deviations.md explains the choice), at once, so libfranka fails fast. A client that
closes and reconnects at once (a program restarting, a test) may be accepted before the loop
has read the old connection's EOF; the old socket is checked for that pending EOF first, so the
returning client is not turned away by its own ghost.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
from typing import Callable

from franka_sim.robot.session import RobotSession, SessionError

log = logging.getLogger(__name__)



def _peer_has_left(transport: asyncio.Transport) -> bool:
    """Whether the peer closed (EOF or reset pending) though the loop has not read it yet."""
    sock = transport.get_extra_info("socket")
    if sock is None:
        return False
    try:
        with socket.socket(fileno=os.dup(sock.fileno())) as peek:
            return peek.recv(1, socket.MSG_PEEK | socket.MSG_DONTWAIT) == b""
    except BlockingIOError:
        return False  # nothing pending: still there
    except OSError:
        return True  # reset


class RobotConnection(asyncio.Protocol):
    def __init__(self, owner: "RobotEndpoint") -> None:
        self.owner = owner
        self.transport: asyncio.Transport | None = None
        self.session: RobotSession | None = None
        self.peer: tuple[str, int] | None = None
    def connection_made(self, transport) -> None:  # type: ignore[override]
        self.transport = transport
        self.peer = transport.get_extra_info("peername")[:2]
        active = self.owner.active
        if active is not None and _peer_has_left(active.transport):
            active.transport.close()
            active.connection_lost(None)  # its disconnect, now rather than next iteration
        if self.owner.active is not None:
            log.warning(
                "refused FCI client %s:%s: the robot is already controlled by %s:%s",
                *self.peer, *self.owner.active.peer,
            )
            transport.close()
            return
        self.owner.active = self
        self.session = self.owner.make_session()
        log.info("client %s:%s connected", *self.peer)

    def data_received(self, data: bytes) -> None:  # type: ignore[override]
        if self.session is None:
            return
        was_connected = self.session.handshake is not None
        try:
            replies = self.session.receive(data)
        except SessionError as exc:
            log.warning("closing connection from %s:%s: %s", *self.peer, exc)
            self.transport.close()
            return
        for reply in replies:
            self.transport.write(reply)
        if not was_connected and self.session.handshake is not None:
            self.owner.on_handshake(self.peer[0], self.session.handshake.udp_port)
        self.owner.after_request()
        if self.session.closed:
            self.transport.close()

    def write(self, data: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(data)

    def connection_lost(self, exc) -> None:  # type: ignore[override]
        if self.owner.active is self:
            self.owner.active = None
            log.info("client %s:%s disconnected", *self.peer)
            self.owner.on_disconnect()


class RobotEndpoint:
    """Accepts FCI clients and routes the active one's traffic."""

    def __init__(
        self,
        make_session: Callable[[], RobotSession],
        on_handshake: Callable[[str, int], None],
        on_disconnect: Callable[[], None],
        after_request: Callable[[], None] = lambda: None,
    ) -> None:
        self.make_session = make_session
        self.after_request = after_request  # the robot's state may have changed
        self.on_handshake = on_handshake
        self.on_disconnect = on_disconnect
        self.active: RobotConnection | None = None
        self.server: asyncio.AbstractServer | None = None

    async def start(self, host: str, port: int) -> None:
        loop = asyncio.get_running_loop()
        self.server = await loop.create_server(
            lambda: RobotConnection(self), host, port, reuse_address=True
        )

    def send(self, data: bytes) -> None:
        """Send an asynchronous reply (e.g. a Move's final status) to the active client."""
        if self.active is not None:
            self.active.write(data)

    async def stop(self) -> None:
        if self.server is not None:
            self.server.close()
        if self.active is not None and self.active.transport is not None:
            self.active.transport.close()
        if self.server is not None:
            await self.server.wait_closed()
