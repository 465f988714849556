"""A TCP endpoint that serves one client at a time, feeding a sans-IO session.

Both the robot (1337) and the Hand (1338) work this way: bytes go to the session, replies come
back out, a malformed message closes that connection with one log line, and a second client
while one is connected is closed at once, so libfranka fails fast. A client that closes and
reconnects at once (a program restarting, a test) may be accepted before the loop has read the
old connection's EOF; the old socket is checked for that pending EOF first, so the returning
client is not turned away by its own ghost. A client the owner deems gone though its
connection is open (the robot: one silent mid-motion, its arm held, see `replaceable`) is
closed to admit the newcomer, as if it had disconnected.

Dead and hostile peers cannot hold the slot (docs/robustness.md). A host that vanishes without
a FIN is found by TCP keepalive within `keepalive`'s idle + interval × count seconds (10 s): its
kernel no longer answers the probes, which a live client's kernel always does, however long its
program stays silent on TCP. A message, once begun, must be complete within `message_deadline`
(the first, Connect, within that of the accept): libfranka writes each message at once, so only
a peer that stalls or trickles trips it. A peer that leaves more than `max_unsent` reply bytes
unread (libfranka reads every reply) is cut off rather than buffered for without end.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
from contextlib import AbstractContextManager, nullcontext
from typing import Callable

from franka_sim.robot.session import Handshake, Session, SessionError
from franka_sim.server.binding import bound_socket
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

KEEPALIVE = (5, 1, 5)  # idle s, probe interval s, probes: a dead peer is found within 10 s
MESSAGE_DEADLINE = 10.0  # s from a message's first byte (or the accept) to its last
MAX_UNSENT = 1 << 20  # bytes of replies a peer may leave unread: ~30 robot models


def _keep_alive(transport: asyncio.Transport, idle: int, interval: int, count: int) -> None:
    """Probe a silent peer; give up on it (and on unacknowledged data) after
    idle + interval × count seconds."""
    sock = transport.get_extra_info("socket")
    if sock is None:
        return
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPIDLE, idle)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPINTVL, interval)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPCNT, count)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_USER_TIMEOUT,
                    1000 * (idle + interval * count))


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


class ClientConnection(asyncio.Protocol):
    def __init__(self, owner: "SingleClientEndpoint") -> None:
        self.owner = owner
        self.transport: asyncio.Transport | None = None
        self.session: Session | None = None
        self.peer: tuple[str, int] | None = None
        self._deadline: asyncio.TimerHandle | None = None  # for the message under way

    def connection_made(self, transport) -> None:  # type: ignore[override]
        self.transport = transport
        self.peer = transport.get_extra_info("peername")[:2]
        owner, active = self.owner, self.owner.active
        if active is not None:
            gone = _peer_has_left(active.transport)
            if not gone and owner.replaceable():
                log.warning("%s client %s:%s silent mid-motion: closed to admit %s:%s",
                            owner.what, *active.peer, *self.peer)
                gone = True
            if gone:
                active.transport.close()
                active.connection_lost(None)  # its disconnect, now rather than next iteration
        if owner.active is not None:
            owner.refused += 1
            if worth_logging(owner.refused):  # a storm of attempts logs a handful of lines
                log.warning("refused %s client %s:%s: already used by %s:%s (%d refused so far)",
                            owner.what, *self.peer, *owner.active.peer, owner.refused)
            transport.close()
            return
        owner.refused = 0
        owner.active = self
        self.session = owner.make_session()
        if owner.taps is not None:
            with owner.lock:  # where it lands is read between two cycles, not inside one
                owner.taps.tcp(owner.what, "open")
        if owner.keepalive is not None:
            _keep_alive(transport, *owner.keepalive)
        self._watch(restart=True)  # Connect is owed from now on
        log.info("%s client %s:%s connected", owner.what, *self.peer)

    def data_received(self, data: bytes) -> None:  # type: ignore[override]
        if self.session is None:
            return
        with self.owner.lock:  # the robot's physics thread shares what the session changes
            if self.owner.taps is not None:
                self.owner.taps.tcp(self.owner.what, "data", data)
            self._receive(data)

    def _receive(self, data: bytes) -> None:
        was_connected = self.session.handshake is not None
        requests = self.session.requests
        try:
            replies = self.session.feed(data)
        except SessionError as exc:
            log.warning("closing %s connection from %s:%s: %s", self.owner.what, *self.peer, exc)
            self.transport.close()
            return
        if not was_connected and self.session.handshake is not None:
            # before its Connect counts as an event: the cycle that follows sees a client
            self.owner.on_handshake(self.peer[0], self.session.handshake)
        if self.session.requests != requests:  # (a Connect alone disturbs nothing)
            self.owner.on_request(was_connected or self.session.requests - requests > 1)
        self._watch(restart=self.session.requests != requests)
        closed = self.session.closed

        def deliver() -> None:
            for reply in replies:
                self.write(reply)
            if closed and self.transport is not None:
                self.transport.close()
        if not self.owner.defer_replies(deliver):
            deliver()

    def _watch(self, restart: bool) -> None:
        """Time the message under way: from its first byte (`restart`: a message completed,
        so any bytes left begin the next) or, before Connect, from the accept."""
        session = self.session
        owed = session.handshake is None or session.buffered > 0
        timer = self._deadline
        if timer is not None and (restart or not owed):
            timer.cancel()
            self._deadline = timer = None
        if owed and timer is None and not session.closed:
            self._deadline = asyncio.get_running_loop().call_later(
                self.owner.message_deadline, self._overdue)

    def _overdue(self) -> None:
        self._deadline = None
        session, transport = self.session, self.transport
        if transport is None or transport.is_closing():
            return
        if session.handshake is None and session.buffered == 0:
            problem = "no Connect"
        else:
            problem = f"a message still incomplete ({session.buffered} bytes of it)"
        log.warning("closing %s connection from %s:%s: %s after %g s", self.owner.what,
                    *self.peer, problem, self.owner.message_deadline)
        transport.close()

    def write(self, data: bytes) -> None:
        transport = self.transport
        if transport is not None and not transport.is_closing():
            transport.write(data)
            if self.owner.taps is not None:
                self.owner.taps.reply(self.owner.what, data)
            unsent = transport.get_write_buffer_size()
            if unsent > self.owner.max_unsent:
                log.warning("closing %s connection from %s:%s: %d reply bytes left unread",
                            self.owner.what, *self.peer, unsent)
                transport.abort()

    def connection_lost(self, exc) -> None:  # type: ignore[override]
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None
        if self.owner.active is self:
            self.owner.active = None
            log.info("%s client %s:%s disconnected", self.owner.what, *self.peer)
            with self.owner.lock:
                self.owner.generation += 1  # (under the lock: see SingleClientEndpoint.send)
                if self.owner.taps is not None:
                    self.owner.taps.tcp(self.owner.what, "close")
                self.owner.on_disconnect()


class SingleClientEndpoint:
    """Accepts clients of one service and routes the active one's traffic."""

    def __init__(
        self,
        what: str,
        make_session: Callable[[], Session],
        on_handshake: Callable[[str, Handshake], None],
        on_disconnect: Callable[[], None],
        defer_replies: Callable[[Callable[[], None]], bool] = lambda deliver: False,
        lock: "AbstractContextManager | None" = None,
        replaceable: Callable[[], bool] = lambda: False,
        on_request: Callable[[bool], None] = lambda disturbing: None,
        keepalive: tuple[int, int, int] | None = KEEPALIVE,
        message_deadline: float = MESSAGE_DEADLINE,
        max_unsent: int = MAX_UNSENT,
        taps=None,
    ) -> None:
        self.what = what  # "FCI", "gripper": names the service in log lines
        self.make_session = make_session
        self.on_handshake = on_handshake
        self.on_disconnect = on_disconnect
        # defer_replies(deliver) → True: the owner calls deliver() later (after the next state).
        self.defer_replies = defer_replies
        # Held while the session or on_handshake/on_disconnect run: what they change (the
        # robot core, the Hand) is shared with the physics thread.
        self.lock = lock if lock is not None else nullcontext()
        # replaceable() → True: the active client counts as gone, and a newcomer replaces it.
        self.replaceable = replaceable
        # on_request(disturbing): the active client's requests were handled (lock held): the
        # clock's cue; not disturbing: its Connect alone (Clock.client_event).
        self.on_request = on_request
        # The bounds on dead and hostile peers (module docstring); a test may shorten them
        # on the instance before clients connect.
        self.keepalive = keepalive  # (idle s, interval s, probes); None: the OS default (off)
        self.message_deadline = message_deadline
        self.max_unsent = max_unsent
        self.active: ClientConnection | None = None
        # Which client is (or was last) active: one more each time a client goes. A cycle's
        # replies are stamped with it under the lock, where the world takes a gone client's
        # pending replies away: a reply stamped before a client went is its, and goes nowhere.
        self.generation = 0
        self.refused = 0  # newcomers turned away while the active client is connected
        self.taps = taps  # the robot's recording taps (server/recorder/taps.py): its traffic
        self.server: asyncio.AbstractServer | None = None

    async def start(self, host: str, port: int) -> None:
        loop = asyncio.get_running_loop()
        self.server = await loop.create_server(lambda: ClientConnection(self),
                                               sock=bound_socket(host, port))

    def send(self, data: bytes, generation: int) -> None:
        """An asynchronous reply (a Move's final status, a gripper action's) to the client that
        was active at `generation`; if it has gone since, to nobody (a reply the world made just
        before a client left must not reach the next one, whose ids start again)."""
        active = self.active
        if active is not None and generation == self.generation:
            active.write(active.session.wire(data))

    async def stop(self) -> None:
        if self.server is not None:
            self.server.close()
        if self.active is not None and self.active.transport is not None:
            self.active.transport.close()
        if self.server is not None:
            await self.server.wait_closed()
