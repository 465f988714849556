"""What an arm's control API does: read the ground truth, reset, move and push bodies, record
(its Desk: operations/arm_desk.py; its network faults: operations/faults.py). Each method is a row
of control/table.py.

Shared by the HTTP adapter (server/control_api.py), an embedded `FrankaSim` and replay. Each
operation checks its arguments first and refuses (franka_sim.control.errors) before anything
changes; then it runs as one job of the cycle thread, between two cycles, so every change takes
effect at a cycle boundary and in lockstep the same calls at the same cycles give the same bits.
Jobs that touch the robot core or the Hand hold the simulator's lock, as a TCP request does.
"""

from __future__ import annotations

import asyncio
import errno
import os
import threading
from typing import Any, Callable

import numpy as np

from franka_sim.config import WORLD_REACH
from franka_sim.control.errors import BadRequest, Conflict, ControlError, NotFound
from franka_sim.description.hand import flange_to_ee
from franka_sim.description.urdf import ArmDescription
from franka_sim.log_names import about, current
from franka_sim.operations.arm_desk import DeskOps
from franka_sim.operations.faults import FaultOps
from franka_sim.operations.ports import Jobs, Pacer
from franka_sim.control.table import Kind
from franka_sim.operations.values import (body_name, mode_name, number, numbers,
                                          refuse_if_failed, within)
from franka_sim.physics.bodies import Immovable, Inside, NotFree, TooViolent, UnknownBody
from franka_sim.protocol.enums import RobotMode
from franka_sim.protocol.errors import ERROR_NAMES
from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.hand import NOMINAL_MAX_WIDTH, Hand
from franka_sim.robot.tool import ToolDevice

BUSY_MODES = (RobotMode.kMove, RobotMode.kAutomaticErrorRecovery)
# The largest push and placement the world stays physical under: under 1000 N at the hand
# the arm's joint limits hold (tens of kN tear it past them, ~1 MN breaks the step); 100 Nm
# turns a link or the cube; WORLD_REACH (config.py) is far beyond any scene; a push
# longer than a minute is a mistyped one (1e300 s would never end).
MAX_PUSH_FORCE = 1000.0
MAX_PUSH_TORQUE = 100.0
MAX_PLACE = WORLD_REACH
MAX_PUSH_DURATION = 60.0


def _pose(state) -> dict:
    return {"position": state.position.tolist(), "quaternion": state.quaternion.tolist(),
            "linear_velocity": state.linear_velocity.tolist(),
            "angular_velocity": state.angular_velocity.tolist(), "free": state.free}


class ArmOps(DeskOps, FaultOps):
    """The control operations on one simulated arm, its Hand (None: none) and its world (whose
    bodies every arm's API sees alike). Arm `arm_index` is robot `arm_index` of the world."""

    kind = Kind.ARM

    def __init__(self, *, core: ArmCore, tool: ToolDevice | None, driver: Pacer,
                 worker: Jobs, lock: threading.Lock, description: ArmDescription,
                 q0, clock: str, client_connected: Callable[[], bool], arm: str = "fr3",
                 arm_index: int = 0, faults=None, taps=None, recordings=None,
                 desk_boot: str = "ready", desk_effects=None,
                 tool_client_connected: Callable[[], bool] = lambda: False) -> None:
        self.core, self.tool, self.driver = core, tool, driver
        # The arm's Desk (operations/arm_desk.py) holds the arm while its brakes are locked or it
        # is not in Execution (--desk-boot locked: from the start, assembly.py holds it);
        # `desk_effects` applies what it means for the robot's endpoints (None: nothing to open
        # or close).
        self.desk_boot, self.desk_effects = desk_boot, desk_effects
        # The Hand's opening is what `gripper_width` (state, reset) speaks of: None without it;
        # the vacuum gripper's state, `vacuum_gripper`. Told apart by the tool's kind.
        kind = None if tool is None else tool.kind
        self.hand: Hand | None = tool if kind == "hand" else None
        self.pump = tool if kind == "vacuum" else None
        self.worker, self.lock, self.description = worker, lock, description
        self.q0 = np.array(q0, dtype=float)
        self.clock = clock
        self.client_connected = client_connected
        self.tool_client_connected = tool_client_connected  # its Hand's or vacuum gripper's
        # the worker's physics: one backend per arm; the arms come first among the robots
        self.arm = arm
        self.arm_index = self.robot_index = arm_index
        # The recording's taps (server/recorder/taps.py): the operations that change the world
        # are recorded with where they ran (None: nothing listens, as in replay).
        self.taps = taps
        # Recordings started and finished through this API (server/recorder/live.py; None:
        # this world cannot be, see start_recording).
        self.recordings = recordings
        self.network_faults = faults  # the world's NetworkFaults (None: none can be injected)

    async def _job(self, fn: Callable[[Any, Any], Any],
                   call: tuple[str, dict] | None = None) -> Any:
        """fn(the world, this arm's body in it: physics/engine.py) in the cycle thread; a
        refusal it raises comes back raised here (and is not logged there as a failed job).
        `call` (operation, arguments): recorded, with the point in the cycle sequence where it
        ran, for replay."""
        index, name = self.arm_index, current()  # (the arm of several this API serves)

        def job(physics):
            taps = self.taps if call is not None else None
            at = taps.position() if taps is not None else None
            try:
                with about(name):  # (what it logs in the cycle thread names the arm too)
                    result = fn(physics.world, physics.arm(index))
            except ControlError as refusal:
                result = refusal
            if taps is not None:
                refused = isinstance(result, ControlError)
                taps.control(self.robot_index, *call, at, result.status if refused else 200,
                             result.message if refused else result)
            return result
        return await self.worker.call(job)

    # -- reading ---------------------------------------------------------------------------------
    def health(self) -> dict:
        """Cheap: no job, no lock (each figure is one attribute read). Failed once the world
        stopped simulating."""
        refuse_if_failed(self.worker)
        core = self.core
        return {"ready": True, "arm": self.arm, "robot": self.description.name,
                "clock": self.clock, "cycle": core.message_id,
                "client_connected": self.client_connected(),
                "tool_client_connected": self.tool_client_connected(),
                "robot_mode": mode_name(core.robot_mode)}

    async def state(self) -> dict:
        def read(world, arm) -> dict:
            with self.lock:
                core = self.core
                m = core.measured if core.measured is not None else arm.measure()
                O_T_EE = m.O_T_F @ flange_to_ee(core.settings.NE_T_EE)
                return {
                    "q": m.q.tolist(), "dq": m.dq.tolist(), "tau_J": m.tau_J.tolist(),
                    "O_T_EE": O_T_EE.tolist(), "robot_mode": mode_name(core.robot_mode),
                    "errors": [ERROR_NAMES[i] for i in np.flatnonzero(core.status.errors)],
                    "success_rate": float(core.success_rate),
                    "gripper_width": None if self.hand is None else float(self.hand.width),
                    "gripper_busy": None if self.hand is None else self.hand.busy,
                    "vacuum_gripper": None if self.pump is None else self.pump.snapshot(),
                    "cycle": core.message_id,
                }
        return await self._job(read)

    async def bodies(self) -> list[dict]:
        def read(world, arm) -> list[dict]:
            bodies = world.bodies
            return [{"name": name, "free": bodies.is_free(name)} for name in bodies.names]
        return await self._job(read)

    async def pose(self, name: str) -> dict:
        name = body_name(name)

        def read(world, arm) -> dict:
            try:
                return _pose(world.body_state(name))
            except UnknownBody:
                raise _no_body(world, name) from None
        return await self._job(read)

    # -- changing ----------------------------------------------------------------------------------
    async def reset(self, q=None, gripper_width=None) -> dict:
        """Arm at rest at q, the robot as it powers up, the Hand open (or `gripper_width`
        apart), and in a world of one arm the bodies as they started: all in one job, or
        nothing (Conflict while busy). Another arm and the bodies of a world of several are
        left as they are (another client may be at work)."""
        q, gripper_width = self._reset_arguments(q, gripper_width)

        def reset(world, arm) -> dict:
            with self.lock:
                self._refuse_busy()
                return self._reset_now(arm, q, gripper_width)
        result = await self._job(reset, ("reset", {
            "q": q.tolist(), "gripper_width": gripper_width}))
        await self._desk_applied()
        return result

    def _reset_arguments(self, q, gripper_width) -> tuple[np.ndarray, float | None]:
        q = self.q0 if q is None else numbers("q", q, 7)
        desc = self.description
        if np.any(q < desc.lower) or np.any(q > desc.upper):
            raise BadRequest(f"q {q.tolist()} is outside the joint limits "
                             f"[{desc.lower.tolist()}, {desc.upper.tolist()}]")
        if gripper_width is not None:
            if self.hand is None:
                raise BadRequest("gripper_width given, but this simulator has no Hand")
            gripper_width = number("gripper_width", gripper_width)
            if not 0.0 <= gripper_width <= NOMINAL_MAX_WIDTH:
                raise BadRequest(f"gripper_width {gripper_width} m is outside "
                                 f"[0, {NOMINAL_MAX_WIDTH}] m")
        return q, gripper_width

    def _refuse_busy(self) -> None:
        """Conflict while a reset would cut something short (cycle thread, lock held)."""
        core, tool = self.core, self.tool
        if core.motion is not None or core.robot_mode in BUSY_MODES:
            raise Conflict(f"the robot is in {mode_name(core.robot_mode)}: a motion or "
                           "an error recovery is under way (let it finish first)")
        if tool is not None and tool.busy:
            raise Conflict("a gripper action is under way (let it finish first)")

    def _reset_now(self, arm, q: np.ndarray, gripper_width: float | None) -> dict:
        """The reset itself (cycle thread, lock held, `_refuse_busy` passed), on this arm's
        body (physics/engine.py ArmBody)."""
        core, tool = self.core, self.tool
        if inside := arm.intrusions(q, gripper_width):  # (a real arm cannot be in the table)
            raise Conflict(f"q {q.tolist()} would put the arm inside another body: "
                           + "; ".join(map(str, inside[:3])))
        last_sent = self.driver.withdraw_prepared()
        arm.reset(q, gripper_width)
        measured = arm.measure()
        core.reset(q, measured, last_sent)
        # The Desk starts again too (on the loop, after this job: `_desk_applied`); its arm
        # is held here, in the same job, so no cycle sees it otherwise.
        core.hold(self.desk_boot != "ready")
        if tool is not None:
            tool.reset(measured.tool)
        if self.network_faults is not None:  # (what faults go on count from the reset world)
            self.network_faults.restart_counts(self.robot_index)
        self.driver.keep_running()
        return {"q": q.tolist(), "cycle": core.message_id,
                "gripper_width": None if self.hand is None else self.hand.width}

    async def home_gripper(self) -> dict:
        if self.hand is None:
            raise NotFound("no Franka Hand on this arm (--tool hand puts one there)")

        def home(world, arm) -> dict:
            with self.lock:
                if not self.hand.home():
                    raise Conflict("the Hand is busy: an action is under way")
            self.driver.keep_running()
            return {"homing": True}
        return await self._job(home, ("home_gripper", {}))

    # -- recording ---------------------------------------------------------------------------------
    async def start_recording(self, path) -> dict:
        """Reset the world (as `reset()`) and record from there into `path` until
        `finish_recording`, in one job: a recording started on a running server then begins
        from the start world, which replay rebuilds in a fresh simulator (docs/recording.md).
        Conflict while a recording runs, a client is connected or a reset would be refused."""
        recordings = self.recordings
        if recordings is None:
            raise Conflict("this simulator cannot record through the control API: a recording "
                           "starts from a reset world, and a reset of one robot of several "
                           "leaves the others as they are (record the whole run with "
                           "`serve --record`)")
        if why := recordings.refused():
            raise Conflict(why)
        if isinstance(path, os.PathLike):  # (an embedder's Path)
            path = os.fspath(path)
        if not isinstance(path, str) or not path:
            raise BadRequest(f"path must be the recording's file path, not {path!r}")
        from franka_sim.recording import mcap_missing

        if missing := mcap_missing():
            raise BadRequest(missing)
        taps = self.taps
        if (busy := recordings.in_the_way()) is not None:  # before the file is opened: it
            raise Conflict(f"already recording to {busy.path}")  # may be this one
        q, _ = self._reset_arguments(None, None)
        try:
            recorder = recordings.open(path)  # here, not in the cycle thread: file I/O
        except (OSError, ValueError) as exc:  # (ValueError: a NUL in the path)
            raise BadRequest(f"cannot record to {path}: {exc.strerror or exc}"
                             if isinstance(exc, OSError) else f"cannot record to {path!r}: {exc}"
                             ) from None

        def start(world, arm) -> dict:
            with self.lock:
                if (busy := recordings.in_the_way()) is not None:
                    raise Conflict(f"already recording to {busy.path}")
                self._refuse_busy()
                recordings.attach(recorder, world)  # Conflict: a client is connected
                at = taps.position()
                result = self._reset_now(arm, q, None)
                taps.control(self.robot_index, "reset", {"q": q.tolist(), "gripper_width": None},
                             at, 200, result)
                return {"path": str(recorder.path), "cycle": result["cycle"]}
        try:
            result = await self._job(start)
        except BaseException:
            recordings.discard(recorder)
            raise
        await self._desk_applied()
        return result

    async def finish_recording(self) -> dict:
        """End the recording `start_recording` began and close its file (a complete MCAP once
        this answers). Conflict when none runs."""
        recordings = self.recordings
        if recordings is None:
            raise Conflict("no recording started through the control API is under way")

        def finish(world, arm) -> tuple:
            with self.lock:
                return recordings.detach(), self.core.message_id
        recorder, cycle = await self._job(finish)
        await asyncio.to_thread(recorder.stop)  # the writer's last drain and the summary
        if (failure := recorder.failure) is not None:  # (a full disk: Insufficient Storage)
            raise ControlError(f"the recording to {recorder.path} stopped when a write failed: "
                               f"{failure.strerror or failure}; the file keeps what reached it "
                               "before", 507 if failure.errno in (errno.ENOSPC, errno.EDQUOT)
                               else 500)
        return {"path": str(recorder.path), "cycle": cycle, "dropped": recorder.dropped}

    async def set_pose(self, name: str, position, quaternion=None) -> dict:
        name = body_name(name)
        position = within("position", numbers("position", position, 3), MAX_PLACE, "m")
        if quaternion is not None:
            quaternion = numbers("quaternion", quaternion, 4)
            if np.abs(quaternion).max() < 1e-9:
                raise BadRequest("quaternion must not be zero (it is normalised)")

        def place(world, arm) -> dict:
            try:
                world.place_body(name, position, quaternion)
            except UnknownBody:
                raise _no_body(world, name) from None
            except NotFree as exc:
                raise Conflict(f"{exc.args[0]!r} is not a free body: {exc.args[1]} (only free "
                               "bodies can be placed)") from None
            except Inside as exc:
                raise Conflict(f"{exc.args[0]!r} placed there would be inside another body: "
                               f"{exc.args[1]}; place it clear of the arm and the scene"
                               ) from None
            self.driver.keep_running()
            return _pose(world.body_state(name))
        return await self._job(place, ("set_pose", {
            "name": name, "position": position.tolist(),
            "quaternion": None if quaternion is None else quaternion.tolist()}))

    async def push(self, body: str, force, torque=None, duration: float = 0.1) -> dict:
        """A wrench at the body's centre of mass, base frame, for `duration` s of simulated
        time (rounded to whole cycles, at least one)."""
        body = body_name(body)
        force = within("force", numbers("force", force, 3), MAX_PUSH_FORCE, "N")
        torque = np.zeros(3) if torque is None else within(
            "torque", numbers("torque", torque, 3), MAX_PUSH_TORQUE, "Nm")
        duration = number("duration", duration)
        if duration <= 0.0:
            raise BadRequest(f"duration must be positive, not {duration}")
        if duration > MAX_PUSH_DURATION:
            raise BadRequest(f"duration {duration:g} s is over the {MAX_PUSH_DURATION:g} s a "
                             "push may last")
        cycles = max(1, round(duration / CYCLE_PERIOD))

        def push(world, arm) -> dict:
            try:
                world.push(body, force, torque, cycles)
            except UnknownBody:
                raise _no_body(world, body) from None
            except Immovable as exc:
                raise Conflict(f"{exc.args[0]!r} does not move under a push: {exc.args[1]}"
                               ) from None
            except TooViolent as exc:
                raise BadRequest(str(exc)) from None
            self.driver.keep_running(cycles)
            return {"body": world.bodies.find(body), "force": force.tolist(),
                    "torque": torque.tolist(), "cycles": cycles}
        return await self._job(push, ("push", {
            "body": body, "force": force.tolist(), "torque": torque.tolist(),
            "duration": duration}))


def _no_body(world, name: str) -> NotFound:
    like = world.bodies.named_like(name)
    hint = f"; did you mean {' or '.join(map(repr, like))}?" if like else ""
    return NotFound(f"no body named {name!r} (GET /bodies lists them{hint})")
