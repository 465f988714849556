"""The UDP side: RobotState out to the connected client, RobotCommand in from it.

States go to (client IP, the port it announced in Connect); libfranka answers from that same
socket, so a datagram from any other address is not the client's and is dropped and counted.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
from typing import Callable

from franka_sim.protocol.codec import decode_command
from franka_sim.protocol.framing import ProtocolError

log = logging.getLogger(__name__)


class UdpEndpoint(asyncio.DatagramProtocol):
    def __init__(self, on_command: Callable[[object], None]) -> None:
        self.on_command = on_command
        self.target: tuple[str, int] | None = None
        self.transport: asyncio.DatagramTransport | None = None
        self._raw: socket.socket | None = None  # the same socket, for the physics thread
        self.dropped_foreign = 0
        self.dropped_malformed = 0

    def connection_made(self, transport) -> None:  # type: ignore[override]
        self.transport = transport
        sock = transport.get_extra_info("socket")
        # A duplicate descriptor of the endpoint's own socket (same port, non-blocking): states
        # leave from the port libfranka answers to, sent by the physics thread directly.
        self._raw = socket.socket(sock.family, sock.type, fileno=os.dup(sock.fileno()))

    def connection_lost(self, exc) -> None:  # type: ignore[override]
        if self._raw is not None:
            self._raw.close()
            self._raw = None

    @property
    def address(self) -> tuple[str, int]:
        return self.transport.get_extra_info("sockname")[:2]

    def send_state(self, data: bytes) -> None:
        """A RobotState to the client, from any thread (the physics thread sends them): a plain
        sendto on the duplicate descriptor, not through the loop."""
        target, raw = self.target, self._raw
        if target is None or raw is None:
            return
        try:
            raw.sendto(data, target)
        except OSError as exc:  # a full buffer or an ICMP error: this one state is lost
            log.debug("state not sent: %s", exc)

    def poll(self) -> None:
        """Take the datagrams already queued on the socket now, from any thread (the physics
        thread, at a motion cycle's deadline: a command that arrived before the deadline
        answers the cycle even if the loop has not read it yet)."""
        raw = self._raw
        if raw is None:
            return
        while True:
            try:
                data, addr = raw.recvfrom(4096)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # an ICMP error queued on the socket
                log.debug("UDP error: %s", exc)
                return
            self.datagram_received(data, addr)

    def datagram_received(self, data: bytes, addr) -> None:  # type: ignore[override]
        if self.target is None or tuple(addr[:2]) != self.target:
            self.dropped_foreign += 1
            if self.dropped_foreign in (1, 10, 100) or self.dropped_foreign % 1000 == 0:
                log.warning(
                    "dropped UDP datagram from %s:%s: not the connected client (%d so far)",
                    addr[0], addr[1], self.dropped_foreign,
                )
            return
        try:
            command = decode_command(data)
        except ProtocolError as exc:
            self.dropped_malformed += 1
            log.warning("dropped UDP datagram from the client: %s", exc)
            return
        self.on_command(command)

    def error_received(self, exc: Exception) -> None:  # type: ignore[override]
        # ICMP port unreachable after a client vanished: nothing to do but keep serving.
        log.debug("UDP error: %s", exc)
