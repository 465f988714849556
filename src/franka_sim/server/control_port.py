"""The control API's port, held from the start, served from its first connection
(server/lazy_port.py): the HTTP server (server/control_api.py, aiohttp) costs ~9 MiB and a
few hundred ms of imports that a robot's first state never needs, and many runs never call
the API."""

from __future__ import annotations

import asyncio

from franka_sim.server.lazy_port import LazyPort


class ControlPort(LazyPort):
    """`ops()`: the robot's implementation of the control API (operations/arm.py, base.py),
    asked for on the first connection;
    `busy(flag)`: the server keeps its clients waiting, or no longer (while loading, a client
    blocked in its first request is not taken for one that stopped answering in lockstep)."""

    what = "the control API"

    def __init__(self, ops, token: str | None = None, busy=lambda _flag: None) -> None:
        super().__init__()
        self.ops, self.token, self.busy = ops, token, busy

    async def _load(self, sock):
        # The import runs in a worker thread: the event loop meanwhile serves the robot.
        self.busy(True)
        try:
            control_api = await asyncio.to_thread(_import_control_api)
            api = control_api.ControlApi(self.ops(), token=self.token)
            await api.serve_socket(sock)
        finally:
            self.busy(False)
        return api


def _import_control_api():
    from franka_sim.footprint import import_without_tls

    import_without_tls("aiohttp.web")  # (a serving process left OpenSSL out: footprint.py)
    from franka_sim.server import control_api

    return control_api
