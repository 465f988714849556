"""A port held from the start and served from its first connection.

What serves it (aiohttp, the control API's ~9 MiB; the Desk's TLS) costs imports and memory a
robot's first state never needs, and many runs never call it. So the port is bound and
listening when the robot starts (a port in use fails the start, saying so), and what serves it
is loaded and takes over the listening socket only when the first connection waits on it: that
client is answered a moment later, nothing is lost (it waits in the backlog), and a process
nobody asks never loads it. The control API's port and the Desk's are two of these.
"""

from __future__ import annotations

import asyncio
import logging
import socket

from franka_sim.server.binding import bound_socket

log = logging.getLogger(__name__)


class LazyPort:
    """`_load(sock)`: what serves the socket, started on it (an object with `stop()`)."""

    backlog = 128
    what = "the port"  # how a failure to serve it is logged

    def __init__(self) -> None:
        self._sock: socket.socket | None = None
        self._server = None  # what serves it, once loaded
        self._serving: asyncio.Task | None = None

    async def start(self, host: str, port: int) -> None:
        """Bind and listen (OSError as binding raises it); serve on the first connection."""
        sock = bound_socket(host, port, backlog=self.backlog)
        self._sock = sock
        asyncio.get_running_loop().add_reader(sock.fileno(), self._first_connection)

    @property
    def loaded(self) -> bool:
        """What serves it was started (someone connected)."""
        return self._server is not None

    def _first_connection(self) -> None:
        loop = asyncio.get_running_loop()
        loop.remove_reader(self._sock.fileno())
        self._serving = loop.create_task(self._serve())

    async def _serve(self) -> None:
        try:
            server = await self._load(self._sock)
        except Exception:
            log.exception("%s could not be served", self.what)
            raise
        self._server = server

    async def _load(self, sock: socket.socket):
        raise NotImplementedError

    async def stop(self) -> None:
        sock, self._sock = self._sock, None
        if sock is None:
            return
        if self._serving is None:
            asyncio.get_running_loop().remove_reader(sock.fileno())
        else:
            try:
                await self._serving
            except Exception:  # logged where it failed
                pass
        if self._server is not None:
            await self._server.stop()
            self._server = None
        sock.close()
