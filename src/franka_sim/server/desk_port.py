"""The Desk's HTTPS port, held from the start, served from its first connection
(server/lazy_port.py).

Only when `--desk-port` is set: the certificate is made or read and the port bound at the
start (either failing fails the start, saying why), and aiohttp with the Desk's routes is
loaded when the first client connects. A simulator without a Desk imports none of it.
"""

from __future__ import annotations

import asyncio

from franka_sim.server.lazy_port import LazyPort


class DeskPort(LazyPort):
    """`robot`: the arm's RobotServer (its Desk, its operations, its effects)."""

    backlog = 64
    what = "the Desk"

    def __init__(self, robot, effects) -> None:
        super().__init__()
        self.robot, self.effects = robot, effects
        self._context = None

    async def start(self, host: str, port: int) -> None:
        from franka_sim.desk.certificate import kept_certificate, server_context

        config = self.robot.config
        kept = config.desk_cert is None
        if not kept:
            cert, key = config.desk_cert, config.desk_key
        else:
            cert, key = await asyncio.to_thread(kept_certificate)
        # (a robot of several: its lines name it)
        self._context = server_context(cert, key, kept=kept)
        await super().start(host, port)

    async def _load(self, sock):
        from franka_sim.server import desk_server

        server = desk_server.DeskServer(self.robot, self.effects)
        await server.serve_socket(sock, self._context)
        return server
