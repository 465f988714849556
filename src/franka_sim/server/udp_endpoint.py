"""The UDP side: RobotState out to the connected client, RobotCommand in from it.

States go to (client IP, the port it announced in Connect); libfranka answers from that same
socket, so a datagram from any other address is not the client's and is dropped and counted.

The event loop opens and closes the socket; the cycle thread sends every state on it and reads
the commands (`read`: the datagrams, decoded and checked, as commands the driver hands to the
cycle) when a cycle needs them: at its deadline, and in lockstep as soon as the answer is there
(the cycle thread watches the socket then). The loop never reads it: a datagram wakes one
thread, the one that runs the cycle, and on a 2-core VM every further wake-up (a reader in the
loop) cost more than a cycle's own work and, in lockstep, ~10 % of the speed, taking the
interpreter from the thread that runs the cycle.

With faults injected (server/faults/), `faults` is this robot's link: every state and every
command from the client passes through it, which drops, holds or lets it through; held
commands reach the robot at the first read after their cycle came. Without, it is None and
the path is as it was.
"""

from __future__ import annotations

import logging
import socket
from franka_sim.protocol.codec import decode_command
from franka_sim.protocol.framing import ProtocolError
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

MAX_READ = 64  # datagrams one poll takes at most (a flood is read over several cycles)


class UdpEndpoint:
    def __init__(self, taps=None) -> None:
        self.target: tuple[str, int] | None = None
        self.sock: socket.socket | None = None
        self.dropped_foreign = 0
        self.dropped_malformed = 0
        self.taps = taps  # the robot's recording taps: every state sent, every datagram dropped
        self.faults = None  # faults.link.ArmLink while faults are injected (cycle thread only)
        self.late: list = []  # commands faults held when they were cleared: the next read's

    def open(self, host: str) -> None:
        """Bind a non-blocking UDP socket on `host` (an ephemeral port)."""
        family, _, _, _, address = socket.getaddrinfo(host, 0, type=socket.SOCK_DGRAM)[0]
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setblocking(False)
            sock.bind(address)
        except OSError:
            sock.close()
            raise
        self.sock = sock

    def close(self) -> None:
        sock, self.sock = self.sock, None
        if sock is not None:
            sock.close()

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()[:2]

    def send_state(self, data: bytes) -> None:
        """A RobotState to the client, from any thread (the physics thread sends them)."""
        target, sock = self.target, self.sock
        if target is None or sock is None:
            return
        if self.faults is not None:
            self._send_through_faults(data, target, sock)
        else:
            try:
                sock.sendto(data, target)
            except OSError as exc:  # a full buffer or an ICMP error: this one state is lost
                log.debug("state not sent: %s", exc)
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
        if self.target is None or tuple(addr[:2]) != self.target:
            self.dropped_foreign += 1
            if self.taps is not None:
                self.taps.rejected("not the connected client", addr, data)
            if worth_logging(self.dropped_foreign):
                log.warning(
                    "dropped UDP datagram from %s:%s: not the connected client (%d so far)",
                    addr[0], addr[1], self.dropped_foreign,
                )
            return None
        try:
            return decode_command(data)
        except ProtocolError as exc:
            self.dropped_malformed += 1
            if self.taps is not None:
                self.taps.rejected(str(exc), addr, data)
            log.warning("dropped UDP datagram from the client: %s", exc)
            return None
