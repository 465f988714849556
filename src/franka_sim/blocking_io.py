"""Blocking socket reads for the clients in the package (the readiness probe, the raw test
client): the server itself reads through asyncio and never blocks."""

from __future__ import annotations

import socket


def recv_exact(sock: socket.socket, n: int) -> bytes:
    """Exactly n bytes from a stream socket; ConnectionError if the peer closes first."""
    out = b""
    while len(out) < n:
        chunk = sock.recv(n - len(out))
        if not chunk:
            raise ConnectionError("the connection was closed by the peer")
        out += chunk
    return out
