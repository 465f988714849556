"""FrankaSim: a simulated world of one or several FR3 arms (and a mobile base), usable as
`async with FrankaSim(...)`.

It wires the pieces and nothing else: description + scene → the cycle thread (which owns the
world's physics), one RobotServer per robot (its core, tools, endpoints and control API on its
own address: server/robot_server.py), the world's cycle (robot/world_cycle.py: every robot's
part around one physics step; a world of one arm is a world too) and the driver that paces it.
Works on any asyncio loop (uvloop is the CLI's choice, not a requirement here).
"""

from __future__ import annotations

import asyncio
import copy
import logging
import threading
from dataclasses import fields

from franka_sim import kernels
from franka_sim.assembly import WorldParts
from franka_sim.config import ClockMode, Config
from franka_sim.config_rules import ConfigError, checked
from franka_sim.log_names import SimName, about
from franka_sim.physics.scene import stands_arms_on_the_base
from franka_sim.operations.embedded import EmbeddedOperations
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.network_faults import NetworkFaults
from franka_sim.recording.metadata import START_FRESH
from franka_sim.server.recorder.live import Recordings
from franka_sim.server.recorder.taps import Taps
from franka_sim.server.robot_server import AddressInUse, RobotServer

__all__ = ["AddressInUse", "ConfigError", "FrankaSim"]

_KINDS = {"fr3": "FR3", "fer": "Panda (FER)"}  # as the start-up line names each arm
log = logging.getLogger(__name__)


class FrankaSim(EmbeddedOperations):
    """The control operations are its async methods, on the first arm (control/table.py:
    `health`, `state`, `reset`, ...; operations/embedded.py)."""

    def __init__(self, config: Config | None = None, **overrides) -> None:
        # A copy: the caller's Config stays as it was (it may make several simulators).
        config = copy.copy(config) if config is not None else Config()
        settings = {f.name for f in fields(Config)}
        for key, value in overrides.items():
            if key not in settings:
                raise TypeError(f"FrankaSim() has no setting {key!r} (franka_sim.config.Config's "
                                f"fields: {', '.join(sorted(settings))})")
            setattr(config, key, value)
        self.config = config = checked(config)  # ConfigError: said now, nothing served
        # What a recording hears, from everyone who has something to record (inert until a
        # recording is attached: server/recorder/live.py).
        self.taps = Taps(len(config.arm_specs()) + (config.mobile_base is not None))
        # SceneError / DescriptionError: said now, before anything is served (an arm that would
        # start inside a body or another arm: by start(), as it builds the world, before
        # serving).
        self.parts = parts = WorldParts(config, self.taps)
        self.urdf_text, self.description, self.scene = (
            parts.urdf_text, parts.description, parts.scene)
        # The arms and the Hands are shared by the cycle thread (each cycle) and the loop (each
        # TCP request): whoever touches them holds this lock (see cycle_driver.py).
        self.lock = threading.Lock()
        self.worker = CycleThread(parts.make_physics)
        self.network_faults = NetworkFaults(seed=config.seed)
        self.driver = CycleDriver(
            self._make_cycle, self.worker, self.lock, deliver=self._deliver,
            clients=self._clients,
            lockstep=config.clock is ClockMode.lockstep, has_client=self._has_client,
            watcher=self.network_faults)
        self.recordings = Recordings(self)
        # Every robot of the world, in the world cycle's order: the arms, then the mobile base.
        # The control API records through a world's only arm (server/recorder/live.py).
        recordings = self.recordings if len(parts.robots) == 1 else None
        self.robots = [
            RobotServer(robot_parts, i, config=config, driver=self.driver, worker=self.worker,
                        lock=self.lock, faults=self.network_faults, taps=self.taps,
                        recordings=recordings, named=len(parts.robots) > 1)
            for i, robot_parts in enumerate(parts.robots)]
        self.arms = [robot for robot in self.robots if robot.parts.kind == "arm"]
        self.base = next((robot for robot in self.robots if robot.parts.kind == "base"), None)
        self.network_faults.wire(self.driver, [robot.udp for robot in self.robots])
        if config.inject:  # (a spec `checked` read already: the faults are imported now)
            from franka_sim.faults import parse_spec

            spec = parse_spec(config.inject)
            for i in range(len(self.robots)):
                self.network_faults.set(i, spec)
        # --record: the whole run, from the world's first cycle (OSError: cannot be written).
        self.recorder = None if config.record is None else self.recordings.open(
            config.record, start=START_FRESH)
        # Its lines' name while other simulators serve in this process (log_names.py).
        self.log_name = SimName(self.robots[0].host)
        self.web = None  # web/live.py LiveView while --web serves it
        self._web_start = None  # the thread starting it (a cancelled start leaves it going)
        self._halting = None  # the stop under way: it runs to its end, cancelled or not
        self._started = False
        self._served = False  # it started once: its threads and sockets are not made again
        self.failed = asyncio.Event()  # set once the world stopped simulating (`failure`)

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> "FrankaSim":
        """Serve every arm, or none: an endpoint that cannot open closes all that did."""
        if self._served:
            raise RuntimeError("a FrankaSim serves once: make a new one to serve again")
        self._served = True
        self.log_name.serving(True)
        with self.log_name.current():  # (what it starts runs under its name)
            return await self._start()

    async def _start(self) -> "FrankaSim":
        try:
            await self.worker.start(on_failure=lambda reason: self.failed.set())
        except BaseException:  # (the world could not be built: an arm inside a body)
            self._discard_recording()
            self.log_name.serving(False)
            raise
        config = self.config
        started = []
        try:
            for robot in self.robots:
                await robot.start()
                started.append(robot)
            await self.driver.start([robot.udp for robot in self.robots])
            if config.web_port:
                await self._start_web()
        except BaseException:  # (a cancel too: what started stops, to its end)
            await self._halt_once(started, keep_recording=False)
            raise
        self._started = True
        try:
            if self.recorder is not None:  # (what the taps queued so far is written first;
                self.recorder.start()  # OSError: another process took the file since)
            self._log_start()
        except BaseException:
            await self.stop()
            raise
        return self

    def _log_start(self) -> None:
        config = self.config
        if not kernels.COMPILED:
            log.info("the cycle runs its numpy kernels (%s): the same states, ~40 %% more CPU a "
                     "cycle (docs/benchmarks.md, The compiled kernels)", kernels.WHY_NUMPY)
        for robot in self.robots:
            with about(robot.log_name):  # (a robot of several: "left: simulated FR3 serving …")
                log.info("simulated %s %s; clock %s; scene %s)",
                         _KINDS[robot.parts.robot] if robot.parts.kind == "arm" else "base",
                         robot.describe(), config.clock.value, self.scene)
        if switches := self._switches():
            log.info("serving with: %s", "; ".join(switches))
        if config.mobile_base is None and stands_arms_on_the_base(self.scene):
            log.warning("the scene %s stands its arms on the mobile base's column: without "
                        "--mobile-base ADDRESS they stand at its sites in the air", self.scene.stem)
        if unplaced := self.parts.unplaced:  # (what the user may have meant is in the scene)
            sites = self.parts.sites
            log.warning("the scene stands arms at its sites %s; arm %s, named for none, "
                        "stands at the world origin (--arm %s puts an arm at its site)",
                        ", ".join(f"arm/{name}" for name in sites), ", ".join(unplaced),
                        " --arm ".join(f"{name}=ADDRESS" for name in sites))

    def _discard_recording(self) -> None:
        """A start that failed: --record's file, which holds nothing of a run, goes."""
        if self.recorder is not None:
            self.recordings.discard(self.recorder)
            self.recorder = None

    def _switches(self) -> list[str]:
        """What this server does beyond serving the robot as it is, for its start's log: a
        reader of the log alone (`docker logs`) sees it recorded, faulted or guarded."""
        config, said = self.config, []
        if config.record is not None:
            said.append(f"recording to {config.record}")
        if config.inject:
            said.append(f"network faults {config.inject} (seed {config.seed})")
        if config.control_token is not None:
            said.append("the control API wants a bearer token")
        for flag, on in (("--enforce-comm-constraints", config.enforce_comm_constraints),
                         ("--enforce-motion-limits", config.enforce_motion_limits)):
            if on:
                said.append(flag)
        return said

    def _snapshot_now(self, _physics, tap) -> None:
        """Cycle thread: the web view's snapshot of the world as it is, each robot's state as
        published (whether or not a client was there to be sent it)."""
        tap.take_now(tuple(robot.core.published() for robot in self.robots))

    def check_serving(self) -> None:
        if not self._started:
            raise RuntimeError("the simulator is not serving: call its operations inside "
                               "`async with FrankaSim(...)` (or between start() and stop())")

    async def stop(self) -> None:
        """Stop serving, to the end even if the caller is cancelled meanwhile (the stop goes on;
        a later stop() waits for it)."""
        if self._halting is None and not self._started:
            return
        await self._halt_once(self.robots, keep_recording=True)

    async def _halt_once(self, robots, *, keep_recording: bool) -> None:
        """Stop `robots` and everything the simulator runs, in one task shielded from the
        caller's cancellation; --record's file is finished, or (a start that failed)
        removed."""
        self._started = False
        if self._halting is None:
            with self.log_name.current():
                self._halting = asyncio.ensure_future(self._halt(robots, keep_recording))
        await asyncio.shield(self._halting)

    async def _halt(self, robots, keep_recording: bool) -> None:
        try:
            await self._halt_all(robots, keep_recording)
        finally:
            self.log_name.serving(False)

    async def _halt_all(self, robots, keep_recording: bool) -> None:
        for robot in robots:  # the robots first: nobody is served once stopping began
            await robot.stop_control_api()
        for robot in robots:
            await robot.stop_endpoints()
        await self.driver.stop()
        for robot in robots:
            robot.udp.close()
        if self.web is not None:  # (its page may take a while to let go: web/live.py)
            if self._web_start is not None:  # (a start cancelled meanwhile: let it end first)
                await asyncio.wait([self._web_start])
                if not self._web_start.cancelled():  # (said to the start's caller, if it
                    self._web_start.exception()      # still waited: not logged again)
            await asyncio.to_thread(self.web.stop)
            self.web = None
        await self.worker.stop()
        if keep_recording:
            self.recordings.close()
        else:
            self._discard_recording()

    async def __aenter__(self) -> "FrankaSim":
        return await self.start()

    async def __aexit__(self, *exc) -> None:
        await self.stop()

    @property
    def failure(self) -> str | None:
        """Why the world stopped simulating (its cycle failed), or None while it runs. Its
        control APIs then answer /health with 503 and this reason; `failed` is set."""
        return self.worker.failure

    async def _start_web(self) -> None:
        """The web view on the first arm's address (web/live.py; viser imported now, in a
        worker thread: the loop meanwhile serves the robots)."""
        from franka_sim.web.live import LiveView

        world = await self.worker.call(lambda physics: physics.world)
        loop, driver, worker = asyncio.get_running_loop(), self.driver, self.worker
        arms = [(robot.name, i) for i, robot in enumerate(self.robots)
                if robot.parts.kind == "arm"]
        view = LiveView(
            self.config.arm_specs()[0].host, self.config.web_port, world.model, world.data,
            arms, attach=lambda tap: setattr(driver, "snapshots", tap),
            refresh=lambda tap: worker.submit(self._snapshot_now, (tap,), lambda _r: None, loop))
        # Known before it starts: a cancel here leaves the thread starting viser, which the
        # stop waits for and then stops.
        self.web = view
        self._web_start = asyncio.ensure_future(asyncio.to_thread(view.start))
        await asyncio.shield(self._web_start)

    # -- the first (or only) arm, as a lone robot's simulator offers it ----------------------------
    @property
    def address(self) -> tuple[str, int]:
        """(host, port) of the first arm's robot endpoint."""
        return self.arms[0].host, self.config.robot_port

    @property
    def core(self):
        return self.arms[0].core

    @property
    def tool(self):
        return self.arms[0].tool

    @property
    def control(self):
        return self.arms[0].control

    @property
    def fci(self):
        """The first arm's FCI endpoint (TCP 1337)."""
        return self.arms[0].fci

    @property
    def udp(self):
        return self.arms[0].udp

    @property
    def tool_endpoint(self):
        return self.arms[0].tool_endpoint

    def operations(self, name: str):
        """The control operations of the robot of that name, as async methods (`await
        sim.operations("right").reset()`; the mobile base's: "base"). KeyError: none."""
        from franka_sim.operations.embedded import ArmOperations, BaseOperations

        for robot in self.robots:
            if robot.name == name:
                kind = ArmOperations if robot.parts.kind == "arm" else BaseOperations
                return kind(self, robot)
        raise KeyError(f"no robot named {name!r} ({', '.join(r.name for r in self.robots)})")

    def arm(self, name: str) -> RobotServer:
        """The arm of that name (KeyError: none)."""
        for arm in self.arms:
            if arm.name == name:
                return arm
        raise KeyError(f"no arm named {name!r} ({', '.join(a.name for a in self.arms)})")

    # -- the world's cycle -------------------------------------------------------------------------
    def _make_cycle(self, physics):
        cycle = self.parts.make_cycle(physics, [robot.tool_state_wanted for robot in self.robots])
        if self.recorder is not None:
            self.recordings.attach(self.recorder, physics.world, cycle=cycle, fresh=True)
        return cycle

    def _clients(self) -> list:
        return [robot.clients() for robot in self.robots]

    def _deliver(self, replies, clients: list) -> None:
        """Each robot's replies of a world cycle, on the loop, once the states have left."""
        for robot, robot_replies, robot_clients in zip(self.robots, replies.robots, clients):
            if robot_replies:
                robot.deliver(robot_replies, robot_clients)

    def _has_client(self) -> bool:
        return any(robot.has_client() for robot in self.robots)
