"""The Franka Hand's sockets: TCP 1338 for commands, UDP for its GripperState stream.

A thin adapter, like the robot's: bytes go to the sans-IO `GripperSession`, replies come back
out, and one client at a time (a second one is closed at once with one log line). States go to
(client IP, the UDP port it announced in Connect) from a socket of our own.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Callable

from franka_sim.robot.gripper_session import GripperSession
from franka_sim.robot.session import SessionError

log = logging.getLogger(__name__)


class GripperConnection(asyncio.Protocol):
    def __init__(self, owner: "GripperEndpoint") -> None:
        self.owner = owner
        self.transport: asyncio.Transport | None = None
        self.session: GripperSession | None = None
        self.peer: tuple[str, int] | None = None

    def connection_made(self, transport) -> None:  # type: ignore[override]
        self.transport = transport
        self.peer = transport.get_extra_info("peername")[:2]
        if self.owner.active is not None:
            log.warning("refused gripper client %s:%s: the hand is already used by %s:%s",
                        *self.peer, *self.owner.active.peer)
            transport.close()
            return
        self.owner.active = self
        self.session = self.owner.make_session()
        log.info("gripper client %s:%s connected", *self.peer)

    def data_received(self, data: bytes) -> None:  # type: ignore[override]
        if self.session is None:
            return
        was_connected = self.session.handshake is not None
        try:
            replies = self.session.receive(data)
        except SessionError as exc:
            log.warning("closing gripper connection from %s:%s: %s", *self.peer, exc)
            self.transport.close()
            return
        for reply in replies:
            self.transport.write(reply)
        if not was_connected and self.session.handshake is not None:
            self.owner.state_target = (self.peer[0], self.session.handshake.udp_port)
        if self.session.closed:
            self.transport.close()

    def write(self, data: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(data)

    def connection_lost(self, exc) -> None:  # type: ignore[override]
        if self.owner.active is self:
            self.owner.active = None
            self.owner.state_target = None
            log.info("gripper client %s:%s disconnected", *self.peer)
            self.owner.on_disconnect()


class GripperEndpoint:
    """Accepts gripper clients, routes the active one's traffic and sends it GripperStates."""

    def __init__(self, make_session: Callable[[], GripperSession],
                 on_disconnect: Callable[[], None]) -> None:
        self.make_session = make_session
        self.on_disconnect = on_disconnect
        self.active: GripperConnection | None = None
        self.state_target: tuple[str, int] | None = None
        self.server: asyncio.AbstractServer | None = None
        self.udp: asyncio.DatagramTransport | None = None

    async def start(self, host: str, port: int) -> None:
        loop = asyncio.get_running_loop()
        self.server = await loop.create_server(
            lambda: GripperConnection(self), host, port, reuse_address=True)
        self.udp, _ = await loop.create_datagram_endpoint(
            asyncio.DatagramProtocol, local_addr=(host, 0))

    def send(self, data: bytes) -> None:
        """A completed action's answer to the active client."""
        if self.active is not None:
            self.active.write(data)

    def send_state(self, data: bytes) -> None:
        if self.state_target is not None and self.udp is not None:
            self.udp.sendto(data, self.state_target)

    async def stop(self) -> None:
        if self.server is not None:
            self.server.close()
        if self.active is not None and self.active.transport is not None:
            self.active.transport.close()
        if self.udp is not None:
            self.udp.close()
        if self.server is not None:
            await self.server.wait_closed()
