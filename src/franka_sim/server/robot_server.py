"""One robot of the world on its own address, whatever its kind (an arm, the mobile base): its
FCI endpoints (TCP 1337 + UDP), its tool's endpoint (an arm's: the Franka Hand on 1338, or
another franka_sim/tools/ row), its control API, opened all or none, and the FCI client it
follows.

What a robot has of its own comes from its parts (assembly.py: `ArmParts`, `BaseParts`): its
core, its tools, its sessions, its name. What the robots share (the cycle thread and its world,
the lock, the driver that paces the world's cycles) is FrankaSim's (server/sim.py), which wires
them.
"""

from __future__ import annotations

import errno
import logging
import threading

from franka_sim.log_names import about
from franka_sim.robot.session import Handshake, Session
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.control_port import ControlPort
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.fci_endpoint import FciEndpoint
from franka_sim.server.tool_endpoint import ToolEndpoint
from franka_sim.server.udp_endpoint import UdpEndpoint

log = logging.getLogger(__name__)


class AddressInUse(OSError):
    """A port on a robot's address is taken (another simulator, or a robot bridge)."""


class RobotServer:
    """Robot `index` of the world (its `parts`); `driver`, `worker`, `lock`: the world's;
    `faults`: the world's NetworkFaults (its control API sets this robot's); `taps`: the
    world's recording taps (server/recorder/taps.py); `recordings`: the control API's
    (server/recorder/live.py; None: this world cannot be recorded that way)."""

    def __init__(self, parts, index: int, *, config, driver: CycleDriver, worker: CycleThread,
                 lock: threading.Lock, faults, taps, recordings, named: bool = False) -> None:
        self.parts, self.index, self.config = parts, index, config
        self.log_name = parts.name if named else None  # a robot of several: lines name it
        self.name, self.host, self.label = parts.name, parts.host, parts.label
        self.driver, self.lock = driver, lock
        self.core, self.tool, self.tool_kind = parts.core, parts.tool, parts.tool_kind
        robot_taps = taps.robots[index]
        self.udp = UdpEndpoint(robot_taps)
        self.fci = FciEndpoint(self._make_session, self._on_handshake, self._on_disconnect,
                                   defer_replies=driver.after_next_state, lock=lock,
                                   replaceable=self._client_silent,
                                   on_request=driver.client_event, taps=robot_taps)
        self.tool_endpoint = None
        if self.tool is not None:
            self.tool_endpoint = ToolEndpoint(
                self.tool_kind.service.name, self._make_tool_session, self._on_tool_disconnect,
                lock=lock, on_request=driver.client_event, taps=robot_taps,
                # as the robot's: a request's answer follows the cycle it landed on, so a
                # client's next request lands on a later one (lockstep numbers each alike)
                defer_replies=driver.after_next_state)
        self.worker, self.faults, self.taps, self.recordings = worker, faults, taps, recordings
        self.desk_effects = None  # what its Desk leaves it in (server/desk_effects.py)
        if parts.kind == "arm" and (config.desk_port or config.desk_boot != "ready"):
            from franka_sim.server.desk_effects import DeskEffects

            self.desk_effects = DeskEffects(self)
        self._control = None  # its operations, made on first use (`control`)
        self._control_api = None  # its port, while it is open (server/control_port.py)
        self._desk_port = None  # the Desk's (server/desk_port.py), while it is open

    @property
    def control(self):
        """Its control operations (operations/arm.py, base.py): what the control API, an
        embedder and its Desk call. Made (and their modules imported) on first use: a server
        nobody calls holds none of them."""
        if self._control is None:
            self._control = self._make_control()
        return self._control

    def _make_control(self):
        parts, config = self.parts, self.config
        connected = lambda: self.fci.active is not None  # noqa: E731
        if parts.kind == "arm":
            from franka_sim.operations.arm import ArmOps

            return ArmOps(
                core=self.core, tool=self.tool, driver=self.driver, worker=self.worker,
                lock=self.lock, description=parts.description, q0=parts.q0,
                clock=config.clock.value, client_connected=connected, arm=self.name,
                arm_index=self.index, faults=self.faults, taps=self.taps,
                recordings=self.recordings, desk_boot=config.desk_boot,
                desk_effects=self.desk_effects and self.desk_effects.apply,
                tool_client_connected=lambda: (self.tool_endpoint is not None
                                               and self.tool_endpoint.active is not None))
        from franka_sim.operations.base import BaseOps

        return BaseOps(self.core, self.lock, config.clock.value, connected, self.worker,
                       robot_index=self.index, faults=self.faults)

    def describe(self) -> str:
        """"serving on HOST:PORT (arm NAME; Hand; control API": the log line's own part."""
        config = self.config
        parts = [self.label]
        if self.parts.kind == "arm":
            parts.append(f"{self.tool_kind.label} on {self.tool_port}" if self.tool is not None
                         else "no tool")
        parts.append(f"control API on {config.control_port}" if config.control_port
                     else "no control API")
        if self.desk_effects is not None and config.desk_port:
            desk = self.control.desk_state
            parts.append(f"Desk on {config.desk_port}, FCI "
                         f"{'active' if desk.fci_active else 'inactive'}, brakes "
                         f"{desk.brakes.lower()}")
        return "serving on {}:{} ({}".format(self.host, config.robot_port, "; ".join(parts))

    # -- lifecycle -------------------------------------------------------------------------------
    async def start(self) -> None:
        """Open every endpoint on the robot's address, or none (AddressInUse / OSError naming
        the robot and the port). What they do later runs under the robot's name (log_names.py:
        the loop's callbacks keep the context they were registered in)."""
        with about(self.log_name):
            await self._start()

    async def _start(self) -> None:
        config, host = self.config, self.host
        opened = []
        effects = self.desk_effects
        try:
            # An inactive FCI (--desk-boot locked) is a closed port until the Desk activates it.
            if effects is None or self.control.desk_state.fci_active:
                await self._open(self.fci.start(host, config.robot_port), config.robot_port, "")
                opened.append(self.fci.stop)
                if effects is not None:
                    effects.fci_open = True
            try:
                self.udp.open(host)
            except OSError as exc:
                raise OSError(exc.errno, f"{self.label}: no UDP socket on {host}: "
                              f"{exc.strerror}") from exc
            if self.tool_endpoint is not None:
                await self._open(self.tool_endpoint.start(host, self.tool_port),
                                 self.tool_port, f" ({self.tool_kind.label})")
                opened.append(self.tool_endpoint.stop)
                if effects is not None:
                    effects.tool_open = True
            if config.control_port:
                await self._open(self._start_control_api(), config.control_port,
                                 " (control API)")
                opened.append(self.stop_control_api)
            if effects is not None and config.desk_port:
                await self._open(self._start_desk(), config.desk_port, " (Desk)")
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
        api = ControlPort(lambda: self.control, token=self.config.control_token,
                          busy=self.driver.server_busy)
        await api.start(self.host, self.config.control_port)
        self._control_api = api

    async def stop_control_api(self) -> None:
        if self._control_api is not None:
            await self._control_api.stop()
            self._control_api = None
        if self._desk_port is not None:
            await self._desk_port.stop()
            self._desk_port = None

    async def _start_desk(self) -> None:
        from franka_sim.server.desk_port import DeskPort

        port = DeskPort(self, self.desk_effects)
        await port.start(self.host, self.config.desk_port)
        self._desk_port = port

    async def stop_endpoints(self) -> None:
        await self.fci.stop()
        if self.tool_endpoint is not None:
            await self.tool_endpoint.stop()

    @property
    def tool_port(self) -> int | None:
        """Its tool's service port (--tool-port, else the tool's own)."""
        if self.tool_kind is None:
            return None
        return self.config.tool_port or self.tool_kind.port

    def has_client(self) -> bool:
        return self.fci.active is not None or (
            self.tool_endpoint is not None and self.tool_endpoint.active is not None)

    # -- the cycle -------------------------------------------------------------------------------
    def tool_state_wanted(self) -> bool:
        """Its tool's client takes its state datagrams (its handshake said where)."""
        endpoint = self.tool_endpoint
        return endpoint is not None and endpoint.state_target is not None

    def clients(self) -> tuple[int, int | None]:
        """The generations of its endpoints' clients (lock held): what a cycle's replies are for."""
        tool = self.tool_endpoint
        return self.fci.generation, (None if tool is None else tool.generation)

    def deliver(self, replies, clients: tuple[int, int | None]) -> None:
        """A cycle's replies (robot/cycle.py Replies), on the loop, once its state has left, to
        the `clients` that were connected when the cycle made them."""
        fci, tool = clients
        for reply in replies.robot:
            self.fci.send(reply, fci)
        for tool_replies, tool_state in replies.tools:
            for reply in tool_replies:
                self.tool_endpoint.send(reply, tool)
            if tool_state is not None:
                self.tool_endpoint.send_state(tool_state)

    # -- the endpoints' callbacks ----------------------------------------------------------------
    def _make_session(self) -> Session:
        self.driver.resume()  # a paused clock starts again for the newcomer
        return self.parts.robot_session()

    def _make_tool_session(self) -> Session:
        self.driver.resume()
        return self.parts.tool_session()

    def _on_handshake(self, peer_ip: str, handshake: Handshake) -> None:
        self.udp.connect(peer_ip, handshake.udp_port, handshake.state, handshake.command)
        self.core.client_connected()

    def _client_silent(self) -> bool:
        with self.lock:
            return self.core.client_silent

    def _on_disconnect(self) -> None:
        self.udp.disconnect()
        self.core.client_gone()
        self.driver.client_event(disturbing=False)

    def _on_tool_disconnect(self) -> None:
        self.tool.client_gone()
        self.driver.client_event(disturbing=False)
