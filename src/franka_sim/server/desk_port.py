"""The Desk's HTTPS port, held from the start, served from its first connection.

Only when `--desk-port` is set: the certificate is made or read and the port bound at the
start (either failing fails the start, saying why), and aiohttp with the Desk's routes is
loaded when the first client connects, as the control API's port does
(server/control_port.py). A simulator without a Desk imports none of it.
"""

from __future__ import annotations

import asyncio
import logging
import socket

log = logging.getLogger(__name__)

BACKLOG = 64


class DeskPort:
    """`robot`: the arm's RobotServer (its Desk, its operations, its effects)."""

    def __init__(self, robot, effects) -> None:
        self.robot, self.effects = robot, effects
        self._sock: socket.socket | None = None
        self._context = None
        self._server = None  # server/desk_server.py DeskServer, once served
        self._serving: asyncio.Task | None = None

    async def start(self, host: str, port: int) -> None:
        from franka_sim.desk.certificate import kept_certificate, server_context

        config = self.robot.config
        if config.desk_cert is not None:
            cert, key = config.desk_cert, config.desk_key
        else:
            cert, key = await asyncio.to_thread(kept_certificate)
        self._context = server_context(cert, key, f"Desk of {self.robot.label}")
        sock = socket.create_server((host, port), backlog=BACKLOG)
        sock.setblocking(False)
        self._sock = sock
        asyncio.get_running_loop().add_reader(sock.fileno(), self._first_connection)

    def _first_connection(self) -> None:
        loop = asyncio.get_running_loop()
        loop.remove_reader(self._sock.fileno())
        self._serving = loop.create_task(self._serve())

    async def _serve(self) -> None:
        try:
            from franka_sim.server import desk_server

            server = desk_server.DeskServer(self.robot, self.effects)
            await server.serve_socket(self._sock, self._context)
        except Exception:
            log.exception("the Desk could not be served")
            raise
        self._server = server

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
