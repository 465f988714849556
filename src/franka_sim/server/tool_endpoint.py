"""A tool's sockets (the Franka Hand's: TCP 1338 for commands, UDP for its GripperState
stream): franka_sim/tools/ says which port and which service.

The TCP side is the same one-client-at-a-time adapter as the robot's (single_client.py);
states go to (client IP, the UDP port it announced in Connect) from a socket of our own.
"""

from __future__ import annotations

import asyncio
import socket
from contextlib import AbstractContextManager
from typing import Callable

from franka_sim.robot.session import Handshake, Session
from franka_sim.server.binding import bound_socket
from franka_sim.server.single_client import SingleClientEndpoint


class ToolEndpoint(SingleClientEndpoint):
    """Accepts a tool's clients (`what`: its service's name, "gripper"), routes the active
    one's traffic and sends it the tool's state datagrams."""

    def __init__(self, what: str, make_session: Callable[[], Session],
                 on_disconnect: Callable[[], None],
                 lock: AbstractContextManager | None = None,
                 on_request: Callable[[bool], None] = lambda disturbing: None, taps=None,
                 defer_replies: Callable[[Callable[[], None]], bool] = lambda deliver: False
                 ) -> None:
        super().__init__(what, make_session, self._on_handshake, self._on_disconnect,
                         defer_replies=defer_replies, lock=lock, on_request=on_request,
                         taps=taps)
        self._client_gone = on_disconnect
        self.state_target: tuple[str, int] | None = None
        self.udp: asyncio.DatagramTransport | None = None

    def _on_handshake(self, peer_ip: str, handshake: Handshake) -> None:
        self.state_target = (peer_ip, handshake.udp_port)

    def _on_disconnect(self) -> None:
        self.state_target = None
        self._client_gone()

    async def start(self, host: str, port: int) -> None:
        await super().start(host, port)
        loop = asyncio.get_running_loop()
        self.udp, _ = await loop.create_datagram_endpoint(
            asyncio.DatagramProtocol, sock=bound_socket(host, 0, socket.SOCK_DGRAM))

    def send_state(self, data: bytes) -> None:
        if self.state_target is not None and self.udp is not None:
            self.udp.sendto(data, self.state_target)
            if self.taps is not None:
                self.taps.tool_state(self.what, data)

    async def stop(self) -> None:
        await super().stop()
        if self.udp is not None:
            self.udp.close()
