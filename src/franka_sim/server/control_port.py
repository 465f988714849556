"""The control API's port, held from the start, served from its first connection.

The HTTP server (server/control_api.py, aiohttp) costs ~9 MiB and a few hundred ms of imports
that a robot's first state never needs, and many runs never call the API. So the port is bound
and listening when the robot starts (a port in use fails the start, as before), and aiohttp is
imported and takes over the listening socket only when the first connection waits on it: that
client's request is answered a moment later, nothing is lost (it waits in the backlog), and a
process nobody asks never loads it.
"""

from __future__ import annotations

import asyncio
import logging
import socket

log = logging.getLogger(__name__)

BACKLOG = 128


class ControlPort:
    """`ops`: the robot's implementation of the control API (operations/arm.py, base.py);
    `busy(flag)`: the server keeps its clients waiting, or no longer (while loading, a client
    blocked in its first request is not taken for one that stopped answering in lockstep)."""

    def __init__(self, ops, token: str | None = None, busy=lambda _flag: None) -> None:
        self.ops, self.token, self.busy = ops, token, busy
        self._sock: socket.socket | None = None
        self._api = None  # server/control_api.py ControlApi, once served
        self._serving: asyncio.Task | None = None

    async def start(self, host: str, port: int) -> None:
        """Bind and listen (OSError as binding raises it); serve on the first connection."""
        sock = socket.create_server((host, port), backlog=BACKLOG)  # (SO_REUSEADDR, as aiohttp)
        sock.setblocking(False)
        self._sock = sock
        asyncio.get_running_loop().add_reader(sock.fileno(), self._first_connection)

    def _first_connection(self) -> None:
        loop = asyncio.get_running_loop()
        loop.remove_reader(self._sock.fileno())
        self._serving = loop.create_task(self._serve())

    async def _serve(self) -> None:
        # The import runs in a worker thread: the event loop meanwhile serves the robot.
        self.busy(True)
        try:
            control_api = await asyncio.to_thread(_import_control_api)
            api = control_api.ControlApi(self.ops, token=self.token)
            await api.serve_socket(self._sock)
        except Exception:
            log.exception("the control API could not be served")
            raise
        finally:
            self.busy(False)
        self._api = api

    @property
    def loaded(self) -> bool:
        """The HTTP server was started (someone connected)."""
        return self._api is not None

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
        if self._api is not None:
            await self._api.stop()
            self._api = None
        sock.close()


def _import_control_api():
    from franka_sim.footprint import import_without_tls

    import_without_tls("aiohttp.web")  # (a serving process left OpenSSL out: footprint.py)
    from franka_sim.server import control_api

    return control_api
