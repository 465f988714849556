"""FrankaSim: one simulated FR3 on one address, usable as `async with FrankaSim(...)`.

It wires the pieces and nothing else: description + scene → the cycle thread (which owns the
physics), robot core, the TCP and UDP endpoints, the Hand (gripper state machine + its
endpoint), the robot's cycle and the driver that paces it, and the control API (HTTP on
`control_port`; its operations are also this object's async methods). Works on any asyncio
loop (uvloop is the CLI's choice, not a requirement here).
"""

from __future__ import annotations

import errno
import logging
import threading

from franka_sim.assembly import ArmParts
from franka_sim.config import ClockMode, Config
from franka_sim.robot.cycle import Replies, RobotCycle
from franka_sim.robot.session import Session
from franka_sim.server.control_ops import ControlOps
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.gripper_endpoint import GripperEndpoint
from franka_sim.server.robot_endpoint import RobotEndpoint
from franka_sim.server.udp_endpoint import UdpEndpoint

log = logging.getLogger(__name__)


class AddressInUse(OSError):
    """The robot port on this address is taken (another simulator, or a robot bridge)."""


class FrankaSim:
    def __init__(self, config: Config | None = None, **overrides) -> None:
        config = config or Config()
        for key, value in overrides.items():
            setattr(config, key, value)
        self.config = config
        self.parts = parts = ArmParts(config)
        self.urdf_text, self.description = parts.urdf_text, parts.description
        self.core, self.scene, self.gripper = parts.core, parts.scene, parts.gripper
        q0 = parts.q0
        self.worker = CycleThread(parts.make_physics)
        # The core and the Hand are shared by the physics thread (each cycle) and the loop
        # (each TCP request): whoever touches them holds this lock (see cycle_driver.py).
        self.lock = threading.Lock()
        self.gripper_endpoint = GripperEndpoint(
            self._make_gripper_session, self._on_gripper_disconnect, lock=self.lock,
            on_request=self._client_event)
        self.udp = UdpEndpoint(self._on_command)
        self.robot = RobotEndpoint(self._make_session, self._on_handshake, self._on_disconnect,
                                   defer_replies=self._defer_replies, lock=self.lock,
                                   replaceable=self._client_silent,
                                   on_request=self._client_event)
        self.driver = CycleDriver(
            self._make_cycle, self.worker, self.lock, self.udp.send_state,
            lockstep=config.clock is ClockMode.lockstep, deliver=self._deliver,
            has_client=self._has_client, poll_commands=self.udp.poll,
            command_socket=lambda: self.udp.sock,
        )
        self.control = ControlOps(
            core=self.core, gripper=self.gripper, driver=self.driver, worker=self.worker,
            lock=self.lock, description=self.description, q0=q0, clock=config.clock.value,
            client_connected=lambda: self.robot.active is not None)
        self._control_api = None  # the HTTP server, while it serves (server/control_api.py)
        self.recorder = None
        if config.record is not None:  # OSError: the target cannot be written
            from franka_sim.recording.taps import install_recorder

            self.recorder = install_recorder(self)
        self._started = False

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> "FrankaSim":
        await self.worker.start()
        try:
            await self.robot.start(self.config.host, self.config.robot_port)
        except OSError as exc:
            await self.worker.stop()
            if exc.errno == errno.EADDRINUSE:
                raise AddressInUse(
                    exc.errno,
                    f"{self.config.host}:{self.config.robot_port} is already in use "
                    "(another franka-sim or robot bridge on this address?)",
                ) from exc
            raise
        # The physics thread alone reads the commands (udp_endpoint).
        try:
            self.udp.open(self.config.host)
        except OSError:
            await self._undo_start()
            raise
        if self.gripper is not None:
            try:
                await self.gripper_endpoint.start(self.config.host, self.config.gripper_port)
            except OSError as exc:
                await self._undo_start()
                if exc.errno == errno.EADDRINUSE:
                    raise AddressInUse(
                        exc.errno, f"{self.config.host}:{self.config.gripper_port} (gripper) is "
                        "already in use (another franka-sim or robot bridge on this address?)",
                    ) from exc
                raise
        await self.driver.start()
        if self.config.control_port:
            try:
                await self._start_control_api()
            except OSError:
                await self.driver.stop()
                if self.gripper is not None:
                    await self.gripper_endpoint.stop()
                await self._undo_start()
                raise
        self._started = True
        if self.recorder is not None:
            self.recorder.start()  # (what the taps queued so far is written first)
        control = (f"control API on {self.config.control_port}" if self.config.control_port
                   else "no control API")
        log.info(
            "simulated FR3 serving on %s:%d (clock %s; %s; %s; scene %s)",
            self.config.host, self.config.robot_port, self.config.clock.value,
            f"Franka Hand on {self.config.gripper_port}" if self.gripper is not None
            else "no gripper", control, self.scene,
        )
        return self

    async def _start_control_api(self) -> None:
        from franka_sim.server.control_api import ControlApi  # aiohttp: only when served

        api = ControlApi(self.control, token=self.config.control_token)
        try:
            await api.start(self.config.host, self.config.control_port)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise AddressInUse(
                    exc.errno, f"{self.config.host}:{self.config.control_port} (control API) is "
                    "already in use (another franka-sim on this address?)") from exc
            raise
        self._control_api = api

    async def _undo_start(self) -> None:
        """A later endpoint could not open: close what start() opened before it."""
        await self.robot.stop()
        self.udp.close()
        await self.worker.stop()

    async def stop(self) -> None:
        if not self._started:
            return
        self._started = False
        if self._control_api is not None:
            await self._control_api.stop()
            self._control_api = None
        await self.robot.stop()
        if self.gripper is not None:
            await self.gripper_endpoint.stop()
        await self.driver.stop()
        self.udp.close()
        await self.worker.stop()
        if self.recorder is not None:
            self.recorder.stop()

    async def __aenter__(self) -> "FrankaSim":
        return await self.start()

    async def __aexit__(self, *exc) -> None:
        await self.stop()

    @property
    def address(self) -> tuple[str, int]:
        """(host, port) of the robot's TCP endpoint."""
        return self.config.host, self.config.robot_port

    # -- the control API's operations (docs/control_api.md), for an embedding program ------------
    async def health(self) -> dict:
        return self.control.health()

    async def state(self) -> dict:
        return await self.control.state()

    async def reset(self, q=None, gripper_width: float | None = None) -> dict:
        return await self.control.reset(q, gripper_width)

    async def bodies(self) -> list[dict]:
        return await self.control.bodies()

    async def pose(self, name: str) -> dict:
        return await self.control.pose(name)

    async def set_pose(self, name: str, position, quaternion=None) -> dict:
        return await self.control.set_pose(name, position, quaternion)

    async def push(self, body: str, force, torque=None, duration: float = 0.1) -> dict:
        return await self.control.push(body, force, torque, duration)

    # -- wiring --------------------------------------------------------------------------------
    def _make_session(self) -> Session:
        self.driver.resume()  # a paused clock starts again for the newcomer
        return self.parts.robot_session()

    def _make_gripper_session(self) -> Session:
        self.driver.resume()
        return self.parts.gripper_session()

    def _client_event(self) -> None:
        self.driver.client_event()  # in lockstep, what releases an idle cycle

    def _defer_replies(self, deliver) -> bool:
        return self.driver.after_next_state(deliver)  # see CycleDriver.after_next_state

    def _has_client(self) -> bool:
        return self.robot.active is not None or self.gripper_endpoint.active is not None

    def _on_handshake(self, peer_ip: str, udp_port: int) -> None:
        self.udp.target = (peer_ip, udp_port)
        self.core.client_connected()

    def _client_silent(self) -> bool:
        with self.lock:
            return self.core.client_silent

    def _on_disconnect(self) -> None:
        self.udp.target = None
        self.core.client_gone()
        self.driver.client_event()

    def _on_command(self, command) -> None:
        self.driver.receive(command)

    def _make_cycle(self, physics) -> RobotCycle:
        cycle = self.parts.make_cycle(
            physics, hand_state_wanted=lambda: self.gripper_endpoint.state_target is not None)
        if self.recorder is not None:
            cycle.recorder = self.recorder
            self.recorder.attach(cycle, physics)
        return cycle

    def _deliver(self, replies: Replies) -> None:
        """A cycle's replies, on the loop, once its state has left."""
        for reply in replies.robot:
            self.robot.send(reply)
        for reply in replies.hand:
            self.gripper_endpoint.send(reply)
        if replies.hand_state is not None:
            self.gripper_endpoint.send_state(replies.hand_state)

    def _on_gripper_disconnect(self) -> None:
        self.gripper.client_gone()
        self.driver.client_event()
