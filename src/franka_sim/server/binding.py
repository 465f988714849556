"""The sockets a robot serves on, bound here rather than by the event loop.

A robot has one address, so every endpoint binds the first address its host resolves to:
the FCI's TCP and UDP, the tool's, the control API and the Desk alike.

Binding here also keeps two costs out of a server that runs for hours, possibly dozens side by
side. An event loop handed a host resolves it on a pool of four threads (uvloop's libuv pool,
~0.2 MiB), and Python resolves a `str` host through its IDNA codec, which imports
`encodings.idna`, `stringprep` and `unicodedata` (~0.4 MiB) even for 127.0.0.1. Here an ASCII
host is resolved as bytes, which skips the codec, in this thread (a name, not an address, may
take a DNS lookup: once, at start).
"""

from __future__ import annotations

import socket


def bound_socket(host: str, port: int, kind: int = socket.SOCK_STREAM,
                 backlog: int = 100) -> socket.socket:
    """A non-blocking socket of `kind` bound to (host, port), listening if it is TCP (address
    reuse on, as asyncio's servers have it); OSError as binding raises it."""
    try:
        name: bytes | str = host.encode("ascii")
    except UnicodeEncodeError:
        name = host
    family, _, _, _, address = socket.getaddrinfo(name, port, type=kind,
                                                  flags=socket.AI_PASSIVE)[0]
    sock = socket.socket(family, kind)
    try:
        sock.setblocking(False)
        if kind == socket.SOCK_STREAM:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        if kind == socket.SOCK_STREAM:
            sock.listen(backlog)
    except OSError:
        sock.close()
        raise
    return sock
