"""What every robot of the world does with its address: open its endpoints (all or none),
name them in errors, serve its control API, close them, and follow its FCI client.

An arm (server/arm_server.py) and the mobile base (server/base_server.py) are both robots on
an address of their own; each names itself (`label`) and says what it has (`gripper`).
"""

from __future__ import annotations

import errno


class AddressInUse(OSError):
    """A port on a robot's address is taken (another simulator, or a robot bridge)."""


class RobotServer:
    """The shared part. A subclass sets `label` ("arm left", "mobile base"), `host`,
    `config`, `core`, `lock`, `driver`, `udp`, `robot`, `control`, `gripper` (None: no Hand)
    and, with a Hand, `gripper_endpoint`; and `_control_api = None`."""

    label: str

    # -- lifecycle -------------------------------------------------------------------------------
    async def start(self) -> None:
        """Open every endpoint on the robot's address, or none (AddressInUse / OSError naming
        the robot and the port)."""
        config, host = self.config, self.host
        opened = []
        try:
            await self._open(self.robot.start(host, config.robot_port), config.robot_port, "")
            opened.append(self.robot.stop)
            try:
                self.udp.open(host)
            except OSError as exc:
                raise OSError(exc.errno, f"{self.label}: no UDP socket on {host}: "
                              f"{exc.strerror}") from exc
            if self.gripper is not None:
                await self._open(self.gripper_endpoint.start(host, config.gripper_port),
                                 config.gripper_port, " (gripper)")
                opened.append(self.gripper_endpoint.stop)
            if config.control_port:
                await self._open(self._start_control_api(), config.control_port,
                                 " (control API)")
        except BaseException:
            for stop in reversed(opened):
                await stop()
            self.udp.close()
            raise

    async def _open(self, opening, port: int, what: str) -> None:
        try:
            await opening
        except OSError as exc:
            where = f"{self.label}: {self.host}:{port}{what}"
            if exc.errno == errno.EADDRINUSE:
                raise AddressInUse(exc.errno, f"{where} is already in use (another franka-sim "
                                   "or robot bridge on this address?)") from exc
            raise OSError(exc.errno, f"{where} cannot be served: {exc.strerror or exc}") from exc

    async def _start_control_api(self) -> None:
        from franka_sim.server.control_api import ControlApi  # aiohttp: only when served

        api = ControlApi(self.control, token=self.config.control_token)
        await api.start(self.host, self.config.control_port)
        self._control_api = api

    async def stop_control_api(self) -> None:
        if self._control_api is not None:
            await self._control_api.stop()
            self._control_api = None

    async def stop_endpoints(self) -> None:
        await self.robot.stop()
        if self.gripper is not None:
            await self.gripper_endpoint.stop()

    def has_client(self) -> bool:
        return self.robot.active is not None or (
            self.gripper is not None and self.gripper_endpoint.active is not None)

    # -- the FCI endpoint's callbacks -------------------------------------------------------------
    def _on_handshake(self, peer_ip: str, udp_port: int) -> None:
        self.udp.connect(peer_ip, udp_port)
        self.core.client_connected()

    def _client_silent(self) -> bool:
        with self.lock:
            return self.core.client_silent

    def _on_disconnect(self) -> None:
        self.udp.disconnect()
        self.core.client_gone()
        self.driver.client_event()
