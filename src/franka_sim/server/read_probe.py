"""Whether a client on this host has read what was sent to it: its UDP socket's receive queue,
as Linux shows it in /proc/net/udp.

A lockstep motion's start sends states the client reads without answering (libfranka's
start-motion handshake, a read before the loop), and each must reach it alone: two waiting in
its socket, it reads only the newer, and the run's message_ids shift by one. Seen from here, the
next can go as soon as the client has read the last (server/clock.py); not seen, the clock
spaces them by a wall-clock time long enough for a loaded machine.

Only a client on a loopback address in this network namespace can be seen: one in a container
or across a network has its socket elsewhere (`probe_for` answers None, and the clock waits as
for any client it cannot see). What is seen is the socket bound to the client's port: a relay
on this host that forwards the states elsewhere is taken for the client. The table is read
whole at each look (~10-40 µs here, a motion's start looks a few times); on a host with
thousands of UDP sockets a look takes milliseconds. A look over LOOK_BUDGET ends looking at
that client (spaced as an unseen one from then on); over a crowded table (CROWDED sockets) it
ends looking at any, since every look would take as long. A small table read slowly says the
machine was busy at that moment, not that the next client's looks will be slow.
"""

from __future__ import annotations

import socket
import time

UDP_TABLE = "/proc/net/udp"
LOOK_BUDGET = 1e-3  # s: a look that takes longer is not worth its wait
CROWDED = 1000  # sockets: a table a look at took longer is not read again by this process
_too_slow: set[str] = set()


def probe_for(target: tuple[str, int] | None, table: str = UDP_TABLE) -> ReadProbe | None:
    """The probe of the socket states go to at `target` (ip, port), if it is a loopback
    address and its socket is in `table`; else None."""
    if target is None or table in _too_slow:
        return None
    ip, port = target[0], target[1]
    try:
        packed = socket.inet_aton(ip)
    except OSError:  # an IPv6 client: its table is not read
        return None
    if packed[0] != 127:
        return None
    # The kernel writes the local address as the 32-bit word in host (little-endian) order.
    keys = (f": {packed[::-1].hex().upper()}:{port:04X} ".encode(),
            f": 00000000:{port:04X} ".encode())  # bound to every address
    probe = ReadProbe(keys, table)
    began = time.monotonic()
    seen = probe.unread() is not None
    if time.monotonic() - began > LOOK_BUDGET:
        too_slow(probe)
        return None
    return probe if seen else None


def too_slow(probe: ReadProbe) -> None:
    """A look took longer than LOOK_BUDGET. Over a crowded table no client's reads are looked
    for in it again: each new connection's first look would hold the cycle thread as long."""
    if probe.sockets > CROWDED:
        _too_slow.add(probe.table)


class ReadProbe:
    def __init__(self, keys: tuple[bytes, ...], table: str = UDP_TABLE) -> None:
        self.keys = keys
        self.table = table
        self.sockets = 0  # in the table at the last look

    def unread(self) -> int | None:
        """Bytes waiting in the client's socket; None: its socket is not there (closed)."""
        try:
            with open(self.table, "rb") as f:
                rows = f.read()
        except OSError:
            return None
        self.sockets = rows.count(b"\n") - 1  # (its first line names the columns)
        for key in self.keys:
            at = rows.find(key)
            if at >= 0:
                # ": local remote st tx_queue:rx_queue ..." (hexadecimal)
                queues = rows[at:rows.find(b"\n", at)].split()[4]
                return int(queues.partition(b":")[2], 16)
        return None
