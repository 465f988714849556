"""The TCP side of the robot (port 1337): one client at a time, as on the real FCI.

A thin adapter: bytes go to the sans-IO `RobotSession`, replies come back out. A second client
while one is connected is closed at once with one log line — the FR3 allows a single FCI
connection (docs/deviations.md explains the choice).
"""

from __future__ import annotations

import asyncio
import logging
from typing import Callable

from franka_sim.robot.session import RobotSession, SessionError

log = logging.getLogger(__name__)


class RobotConnection(asyncio.Protocol):
    def __init__(self, owner: "RobotEndpoint") -> None:
        self.owner = owner
        self.transport: asyncio.Transport | None = None
        self.session: RobotSession | None = None
        self.peer: tuple[str, int] | None = None

    def connection_made(self, transport) -> None:  # type: ignore[override]
        self.transport = transport
        self.peer = transport.get_extra_info("peername")[:2]
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
    ) -> None:
        self.make_session = make_session
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
