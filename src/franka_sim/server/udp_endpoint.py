"""The UDP side: RobotState out to the connected client, RobotCommand in from it.

States go to (the address the TCP connection came from, the port the client announced in
Connect). libfranka answers each state to wherever it came from, from whatever source address
its route to the robot gives it: the TCP peer's, unless an address translation lies between
them. Docker's userland proxy with a client on the host connecting to the host's own address is
one: the TCP connection arrives from that address, the commands from the bridge's gateway.
So commands are taken from one address at a time (`source`), at first the TCP peer's; a
datagram from another address moves `source` there when it is this connection's answer: a
well-formed RobotCommand echoing the message_id of a state sent to this connection (one log
line the first time in a connection, counted in `sources_moved`). Anything else from another
address is dropped and counted. The price: a stranger that echoes a plausible message_id is
taken for the client (docs/robustness.md). The normal case costs one comparison per datagram.

The event loop opens and closes the socket; the cycle thread sends every state on it and reads
the commands (`read`: the datagrams, decoded and checked, as commands the driver hands to the
cycle) when a cycle needs them: at its deadline, and in lockstep as soon as the answer is there
(the cycle thread watches the socket then). The loop never reads it: a
datagram wakes one thread, the one that runs the cycle, and on a 2-core VM every further
wake-up (a reader in the loop) cost more than a cycle's own work and, in lockstep, ~10 % of
the speed, taking the interpreter from the thread that runs the cycle.

With faults injected (server/network_faults.py), `faults` is this robot's link: every state and every
command from the client passes through it, which drops, holds or lets it through; held
commands reach the robot at the first read after their cycle came. Without, it is None and
the path is as it was.
"""

from __future__ import annotations

import logging
import socket
import sys
from typing import Callable

from franka_sim.protocol.codec import decode_command
from franka_sim.protocol.framing import ProtocolError
from franka_sim.protocol.robot_command import ROBOT_COMMAND_SIZE
from franka_sim.log_names import about, current
from franka_sim.server.binding import bound_socket
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)
RECEIVE_BUFFER = 1 << 20  # bytes asked for the robot's UDP socket (see `open`)
# Linux's option past rmem_max (33 there; Python does not name it), None elsewhere
SO_RCVBUFFORCE = getattr(socket, "SO_RCVBUFFORCE", 33 if sys.platform == "linux" else None)

MAX_READ = 64  # datagrams one read takes at most (a flood is read over several cycles)


class UdpEndpoint:
    def __init__(self, taps=None) -> None:
        self.target: tuple[str, int] | None = None  # where states go (connect/disconnect)
        self.source: tuple[str, int] | None = None  # where commands are taken from
        self.sock: socket.socket | None = None
        self.log_name: str | None = None  # the robot of several it serves (its lines name it)
        self._written: Callable[[bytes], bytes] | None = None  # an older client's state form
        self._read: Callable[[bytes], bytes] | None = None  # and its commands'
        # The first and the newest state sent to this connection: the message_ids between them
        # are the ones its answers may echo.
        self._first_sent: bytes | None = None
        self._last_sent: bytes | None = None
        self._moves = 0  # times `source` moved in this connection (its first move is logged)
        self.sources_moved = 0
        self.dropped_foreign = 0
        self.dropped_malformed = 0
        # The address the last client's commands came from, until the next connects: what it
        # sent before it saw its connection close (the Desk cut it off, it left mid-motion)
        # is dropped and counted apart, without a warning: it is no stranger.
        self._departed: tuple[str, int] | None = None
        self.dropped_departed = 0
        self.taps = taps  # the robot's recording taps: every state sent, every datagram dropped
        self.faults = None  # faults.link.ArmLink while faults are injected (cycle thread only)
        self.late: list = []  # commands faults held when they were cleared: the next read's

    def open(self, host: str) -> None:
        """Bind a non-blocking UDP socket on `host` (an ephemeral port). Its lines name the
        robot it opens for (its datagrams are read in the cycle thread, outside that name)."""
        self.sock = bound_socket(host, 0, socket.SOCK_DGRAM)
        # Room for a burst of a stranger's datagrams (read and dropped one cycle later) beside
        # the client's command: the kernel's default, ~200 KiB, fills with a few hundred KB and
        # then drops the command too. Past net.core.rmem_max where the server may (CAP_NET_ADMIN),
        # else up to it; memory is taken only while datagrams wait.
        try:
            if SO_RCVBUFFORCE is None:
                raise OSError
            self.sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, RECEIVE_BUFFER)
        except OSError:  # (PermissionError: not privileged)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
        self.log_name = current()

    def _say(self, level: int, message: str, *args) -> None:
        with about(self.log_name):
            log.log(level, message, *args)

    def close(self) -> None:
        sock, self.sock = self.sock, None
        if sock is not None:
            sock.close()

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()[:2]

    def connect(self, peer_ip: str, udp_port: int,
                written: Callable[[bytes], bytes] | None = None,
                read: Callable[[bytes], bytes] | None = None) -> None:
        """A client's handshake: its states go to `udp_port` at the address its TCP
        connection came from, and its commands are expected from there. A client of an older
        protocol version: `written`, how each state is written for it, `read`, how its
        commands read as v10's (Handshake.state, .command)."""
        self._first_sent = self._last_sent = None
        self._moves = 0
        self._written, self._read = written, read
        self.source = self.target = (peer_ip, udp_port)
        self._departed = None

    def disconnect(self) -> None:
        self._departed = self.source
        self.source = self.target = None
        self._first_sent = self._last_sent = None
        self._written = self._read = None

    def send_state(self, data: bytes) -> None:
        """A RobotState to the client, from any thread (the physics thread sends them)."""
        target, sock = self.target, self.sock
        if target is None or sock is None:
            return
        wire = data if self._written is None else self._written(data)
        if self.faults is not None:
            self._send_through_faults(wire, target, sock)
        else:
            try:
                sock.sendto(wire, target)
            except OSError as exc:  # a full buffer or an ICMP error: this one state is lost
                log.debug("state not sent: %s", exc)
        if self._first_sent is None:
            self._first_sent = data
        self._last_sent = data
        if self.taps is not None:
            self.taps.sent(data)  # what the robot sent, whatever the network made of it

    def _send_through_faults(self, data: bytes, target, sock) -> None:
        link = self.faults
        if link.client != target:
            link.new_client(target)
        for datagram in link.states_out(int.from_bytes(data[:8], "little"), data):
            try:
                sock.sendto(datagram, target)
            except OSError as exc:
                log.debug("state not sent: %s", exc)

    def read(self, limit: int = MAX_READ) -> list:
        """The commands that arrived (up to `limit` datagrams read now), decoded and checked,
        in order; from the cycle thread."""
        sock = self.sock
        if sock is None:
            return []
        commands = []
        if self.late:
            commands, self.late = self.late, []
        faults = self.faults
        if faults is not None:
            commands.extend(faults.commands_due())
        for _ in range(limit):
            try:
                data, addr = sock.recvfrom(4096)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:  # an ICMP error queued on the socket
                log.debug("UDP error: %s", exc)
                break
            command = self.accept(data, addr)
            if command is None:
                continue
            if faults is not None:
                commands.extend(faults.command_in(command))
            else:
                commands.append(command)
        return commands

    def accept(self, data: bytes, addr):
        """The RobotCommand in a datagram, or None: not the client's, or malformed (dropped,
        counted and logged)."""
        if self._read is not None:  # an older client's command, as v10 has it
            data = self._read(data)
        if addr[:2] != self.source:  # (None while no client is connected)
            return self._from_elsewhere(data, addr)
        try:
            return decode_command(data)
        except ProtocolError as exc:
            self.dropped_malformed += 1
            if self.taps is not None:
                self.taps.rejected(str(exc), addr, data)
            self._say(logging.WARNING, "dropped UDP datagram from the client: %s", exc)
            return None

    def _from_elsewhere(self, data: bytes, addr):
        """Not from `source`: this connection's answer coming through an address translation
        moves `source` and is taken; anything else is dropped (None)."""
        command = self._answer(data)
        target = self.target
        if target is None and addr[:2] == self._departed:
            self.dropped_departed += 1
            if self.taps is not None:
                self.taps.rejected("from the client that left", addr, data)
            log.debug("dropped UDP datagram from the client that left (%d so far)",
                      self.dropped_departed)
            return None
        if command is None or target is None:
            self.dropped_foreign += 1
            if self.taps is not None:
                self.taps.rejected("not the connected client", addr, data)
            if worth_logging(self.dropped_foreign):
                self._say(
                    logging.WARNING,
                    "dropped UDP datagram from %s:%s: not the connected client (%d so far)",
                    addr[0], addr[1], self.dropped_foreign,
                )
            return None
        self.source = addr[:2]
        self.sources_moved += 1
        self._moves += 1
        if worth_logging(self._moves):
            self._say(
                logging.INFO,
                "UDP commands of the client at %s come from %s:%s (an address translation "
                "between them?): taken from there; its states still go to %s:%s (move %d of this "
                "connection)",
                target[0], addr[0], addr[1], target[0], target[1], self._moves,
            )
        return command

    def _answer(self, data: bytes):
        """The RobotCommand in `data` if it is well-formed and echoes the message_id of a state
        sent to this connection; else None."""
        first, last = self._first_sent, self._last_sent
        if first is None or last is None or len(data) != ROBOT_COMMAND_SIZE:
            return None
        echoed = int.from_bytes(data[:8], "little")
        if not _message_id(first) <= echoed <= _message_id(last):
            return None
        try:
            return decode_command(data)
        except ProtocolError:
            return None


def _message_id(state: bytes) -> int:
    return int.from_bytes(state[:8], "little")  # a RobotState's first field
