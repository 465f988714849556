"""FrankaSim: a simulated world of one or several FR3 arms, usable as `async with FrankaSim(...)`.

It wires the pieces and nothing else: description + scene → the cycle thread (which owns the
world's physics), one ArmServer per arm (its robot core, Hand, endpoints and control API on its
own address: server/arm_server.py), the world's cycle and the driver that paces it. With one
arm the driver runs that arm's RobotCycle; with several, a WorldCycle (robot/world_cycle.py)
around one physics step for all. Works on any asyncio loop (uvloop is the CLI's choice, not a
requirement here).
"""

from __future__ import annotations

import asyncio
import logging
import threading

from franka_sim.assembly import WorldParts
from franka_sim.config import ClockMode, Config
from franka_sim.operations.embedded import EmbeddedOperations
from franka_sim.physics.mujoco_backend import ArmBackend
from franka_sim.server.arm_server import ArmServer
from franka_sim.server.base_server import BaseServer
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.robot_server import AddressInUse
from franka_sim.server.faults import NetworkFaults, parse_spec

__all__ = ["AddressInUse", "FrankaSim"]

log = logging.getLogger(__name__)


class FrankaSim(EmbeddedOperations):
    """The control operations are its async methods, on the first arm (operations/table.py:
    `health`, `state`, `reset`, ...; operations/embedded.py)."""

    def __init__(self, config: Config | None = None, **overrides) -> None:
        config = config or Config()
        for key, value in overrides.items():
            setattr(config, key, value)
        self.config = config
        # SceneError / DescriptionError: said now, before anything is served.
        self.parts = parts = WorldParts(config)
        self.urdf_text, self.description, self.scene = (
            parts.urdf_text, parts.description, parts.scene)
        # The arms and the Hands are shared by the cycle thread (each cycle) and the loop (each
        # TCP request): whoever touches them holds this lock (see cycle_driver.py).
        self.lock = threading.Lock()
        self.worker = CycleThread(parts.make_physics)
        one = len(parts.arms) == 1 and parts.base is None
        self.driver = CycleDriver(
            self._make_cycle, self.worker, self.lock, self._send_states,
            lockstep=config.clock is ClockMode.lockstep, deliver=self._deliver,
            has_client=self._has_client, poll_commands=self._poll,
            command_socket=(lambda: self.arms[0].udp.sock) if one else
            (lambda: tuple(robot.udp.sock for robot in self.robots)),
        )
        self.network_faults = NetworkFaults(self.driver, seed=config.seed)
        self.arms = [
            ArmServer(arm_parts, i, driver=self.driver, worker=self.worker, lock=self.lock,
                      faults=self.network_faults,
                      on_command=self.driver.receive if one else
                      (lambda command, i=i: self.driver.receive((i, command))))
            for i, arm_parts in enumerate(parts.arms)]
        # Every robot of the world, in the world cycle's order: the arms, then the mobile base.
        self.robots = list(self.arms)
        self.base = None
        if parts.base is not None:
            index = len(self.arms)
            self.base = BaseServer(parts.base, config.mobile_base, config, index=index,
                                   driver=self.driver, worker=self.worker, lock=self.lock,
                                   faults=self.network_faults, on_command=lambda command:
                                   self.driver.receive((index, command)))
            self.robots.append(self.base)
        if one:  # the one arm's own endpoints, without a per-cycle loop over a list
            self.driver.send_state = self.arms[0].udp.send_state
            self.driver.deliver = self.arms[0].deliver
            self.driver.poll_commands = self.arms[0].udp.poll
        self.network_faults.wire(robot.udp for robot in self.robots)
        if config.inject:  # FaultSpecError: said now, before anything is served
            spec = parse_spec(config.inject)
            for i in range(len(self.robots)):
                self.network_faults.set(i, spec)
        self.recorder = None
        if config.record is not None:  # OSError: the target cannot be written
            if not one:
                raise ValueError("--record records a world of one arm (several, or a mobile "
                                 "base: not supported)")
            from franka_sim.recording.taps import install_recorder

            self.recorder = install_recorder(self)
        self.recordings = None  # the control API's (recording/live.py): a world of one arm
        if one:
            from franka_sim.recording.live import LiveRecordings

            self.recordings = self.control.recordings = LiveRecordings(self)
        self._started = False
        self.failed = asyncio.Event()  # set once the world stopped simulating (`failure`)

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> "FrankaSim":
        """Serve every arm, or none: an endpoint that cannot open closes all that did."""
        await self.worker.start(on_failure=lambda reason: self.failed.set())
        started = []
        try:
            for robot in self.robots:
                await robot.start()
                started.append(robot)
            await self.driver.start()
        except BaseException:
            for arm in reversed(started):
                await arm.stop_control_api()
                await arm.stop_endpoints()
                arm.udp.close()
            await self.worker.stop()
            raise
        self._started = True
        if self.recorder is not None:
            self.recorder.start()  # (what the taps queued so far is written first)
        config = self.config
        for robot in self.robots:
            log.info("simulated %s %s; clock %s; scene %s)",
                     "FR3" if robot in self.arms else "base", robot.describe(),
                     config.clock.value, self.scene)
        return self

    async def stop(self) -> None:
        if not self._started:
            return
        self._started = False
        for robot in self.robots:
            await robot.stop_control_api()
        for robot in self.robots:
            await robot.stop_endpoints()
        await self.driver.stop()
        for robot in self.robots:
            robot.udp.close()
        await self.worker.stop()
        if self.recorder is not None:
            self.recorder.stop()
        if self.recordings is not None:
            self.recordings.close()

    async def __aenter__(self) -> "FrankaSim":
        return await self.start()

    async def __aexit__(self, *exc) -> None:
        await self.stop()

    @property
    def failure(self) -> str | None:
        """Why the world stopped simulating (its cycle failed), or None while it runs. Its
        control APIs then answer /health with 503 and this reason; `failed` is set."""
        return self.worker.failure

    # -- the first (or only) arm, as a lone robot's simulator offers it ----------------------------
    @property
    def address(self) -> tuple[str, int]:
        """(host, port) of the first arm's robot endpoint."""
        return self.arms[0].host, self.config.robot_port

    @property
    def core(self):
        return self.arms[0].core

    @property
    def gripper(self):
        return self.arms[0].gripper

    @property
    def control(self):
        return self.arms[0].control

    @property
    def robot(self):
        return self.arms[0].robot

    @property
    def udp(self):
        return self.arms[0].udp

    @property
    def gripper_endpoint(self):
        return self.arms[0].gripper_endpoint

    def arm(self, name: str) -> ArmServer:
        """The arm of that name (KeyError: none)."""
        for arm in self.arms:
            if arm.spec.name == name:
                return arm
        raise KeyError(f"no arm named {name!r} ({', '.join(a.spec.name for a in self.arms)})")

    # -- the world's cycle -------------------------------------------------------------------------
    def _make_cycle(self, physics: list[ArmBackend]):
        cycle = self.parts.make_cycle(physics, [arm.hand_state_wanted for arm in self.arms])
        if self.recorder is not None:
            cycle.recorder = self.recorder
            self.recorder.attach(cycle, physics[0])
        return cycle

    def _send_states(self, states: tuple) -> None:
        """Each arm's state of a world cycle to its client (None: packing failed)."""
        for robot, state in zip(self.robots, states):
            if state is not None:
                robot.udp.send_state(state)

    def _deliver(self, replies) -> None:
        """Each arm's replies of a world cycle, on the loop, once the states have left."""
        for robot, robot_replies in zip(self.robots, replies.arms):
            if robot_replies:
                robot.deliver(robot_replies)

    def _poll(self, *limit) -> None:
        for robot in self.robots:
            robot.udp.poll(*limit)

    def _has_client(self) -> bool:
        return any(robot.has_client() for robot in self.robots)
