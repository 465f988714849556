"""A userland TCP proxy, as Docker's publishes a port: the client connects to the front
address, the proxy connects on to the server from an address of its own.

The server then sees the TCP connection come from `via`, while the client's UDP answers come
from the client's own source address: the address translation libfranka meets behind Docker's
userland proxy, on loopback. Threads in the test process: the client must be another process
(pylibfranka's blocking calls hold the GIL).
"""

from __future__ import annotations

import socket
import threading
from contextlib import contextmanager


def _pump(source: socket.socket, sink: socket.socket) -> None:
    """Bytes from `source` to `sink` until `source` ends; then `sink` is told so."""
    try:
        while data := source.recv(65536):
            sink.sendall(data)
    except OSError:  # the other direction closed both sockets
        pass
    finally:
        try:
            sink.shutdown(socket.SHUT_WR)
        except OSError:
            pass


def _serve(listener: socket.socket, upstream: tuple[str, int], via: str,
           connections: list) -> None:
    while True:
        try:
            client, _ = listener.accept()
        except OSError:  # the listener was closed: the proxy stops
            return
        server = socket.socket()
        try:
            server.bind((via, 0))
            server.connect(upstream)
        except OSError:
            client.close()
            server.close()
            continue
        connections.append((client, server))
        for a, b in ((client, server), (server, client)):
            threading.Thread(target=_pump, args=(a, b), daemon=True).start()


@contextmanager
def tcp_proxy(front: str, upstream: tuple[str, int], via: str, port: int | None = None):
    """Listen on (front, port or upstream's port), forward each connection to `upstream`
    from `via`; everything is closed when the block ends."""
    listener = socket.socket()
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind((front, port or upstream[1]))
    listener.listen()
    connections: list = []
    thread = threading.Thread(target=_serve, args=(listener, upstream, via, connections),
                              daemon=True)
    thread.start()
    try:
        yield
    finally:
        try:
            listener.shutdown(socket.SHUT_RDWR)  # wakes the accept (close alone would not)
        except OSError:
            pass
        listener.close()
        thread.join(5)
        for pair in connections:
            for sock in pair:
                sock.close()
