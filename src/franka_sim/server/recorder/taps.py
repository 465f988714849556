"""The recording's taps: one object, handed in at construction to everyone who has something to
record, that keeps what they hand it while a recording runs.

`Taps` hears the world (robot/events.py WorldEvents: each cycle released or repeated; the
control operations; log lines) and gives each robot its `RobotTaps` (its robot/events.py
RobotEvents: a command taken and its fate, a cycle lost; its endpoints' traffic: states sent,
datagrams rejected, TCP bytes and replies, tool states). While no recording runs (`recorder`
None) a tap costs one test. `franka-sim serve --record` attaches a Recorder before the world
serves; the control API's `/recording` attaches one between two cycles (server/recorder/live.py)
and takes it off the same way: nothing else is touched.

Every tap appends one small tuple to the recorder's queue and returns, in the order the events
happened: the cycle thread's taps run in it, the TCP taps under the simulator's lock, the control
operations' in the cycle thread's jobs. Each event that changes the robot records *where* in the
cycle sequence it landed: the id of the last released cycle and whether that cycle had completed
(a realtime server releases an idle cycle ahead of its deadline, so an event can fall between a
cycle's release and its completion). That is what replay needs to apply it at the same point.
"""

from __future__ import annotations

import logging
import time

from franka_sim import log_names
from franka_sim.robot.events import RobotEvents, WorldEvents
from franka_sim.server.recorder import events as ev

POSE_EVERY = 10  # cycles between two records of the world's free bodies (100 Hz)


class Taps(WorldEvents):
    """The taps of a world of `robots` robots (by index, in the world cycle's order)."""

    def __init__(self, robots: int) -> None:
        self.recorder = None  # the Recorder under way, or None
        self.robots = tuple(RobotTaps(self, index) for index in range(robots))
        self._cycle = None  # the world's cycle: where an event lands
        self._qpos = None  # the world's qpos (a view), copied every POSE_EVERY cycles
        self._log_tap: logging.Handler | None = None

    def attach(self, recorder, cycle, qpos) -> None:
        """Record into `recorder` from now on (cycle thread, between two cycles, or before the
        world serves): `cycle` is the world's, `qpos` its positions (a view)."""
        self._cycle, self._qpos = cycle, qpos
        self.recorder = recorder
        self._log_tap = _LogTap(self)
        logging.getLogger().addHandler(self._log_tap)

    def detach(self):
        """Stop recording (cycle thread, between two cycles); the Recorder, to be stopped."""
        recorder, self.recorder = self.recorder, None
        if self._log_tap is not None:
            logging.getLogger().removeHandler(self._log_tap)
            self._log_tap = None
        return recorder

    def position(self) -> tuple[int, bool]:
        """(last released cycle, whether it has completed): where an event lands."""
        cycle = self._cycle
        if cycle is None:
            return 0, True
        n = cycle.message_id
        return n, cycle.parts[0].completed_id == n

    # -- the world (cycle thread) -----------------------------------------------------------------
    def released(self, message_id: int) -> None:
        recorder = self.recorder
        if recorder is not None and message_id % POSE_EVERY == 0 and self._qpos is not None:
            recorder.put((ev.POSES, message_id, self._qpos.copy(), time.time_ns()))

    def repeated(self, message_id: int) -> None:
        """(The writer keeps runs of them as one message: an idle lockstep client sees a
        repeat each ms.)"""
        recorder = self.recorder
        if recorder is not None:
            recorder.put((ev.REPEATED, message_id, time.time_ns()))

    def skipped(self, first: int, last: int) -> None:
        recorder = self.recorder
        if recorder is not None:
            recorder.put((ev.SKIPPED, first, last, time.time_ns()))

    def control(self, robot: int, operation: str, arguments: dict, at: tuple[int, bool],
                status: int, result) -> None:
        """A control operation ran (cycle thread) at `at` (position() before it ran)."""
        recorder = self.recorder
        if recorder is not None:
            recorder.put((ev.CONTROL, robot, operation, arguments, status, result, at[0], at[1],
                          time.time_ns()))

    def log(self, record: logging.LogRecord) -> None:
        try:
            message = record.getMessage()
        except Exception:  # noqa: BLE001 - a bad log call must not break the caller
            message = str(record.msg)
        recorder = self.recorder
        if recorder is not None:
            recorder.put((ev.LOG, int(record.created * 1e9), record.levelname, record.name,
                          message, log_names.current()))


class RobotTaps(RobotEvents):
    """One robot's taps (`index` in the world)."""

    def __init__(self, world: Taps, index: int) -> None:
        self.world, self.index = world, index

    # -- what the robot emits (robot/events.py; cycle thread) -------------------------------------
    def command(self, command, on_time: bool) -> None:
        recorder = self.world.recorder
        if recorder is not None:
            n, completed = self.world.position()
            recorder.put((ev.COMMAND, self.index, command, on_time, n, completed,
                          time.time_ns()))

    def lost(self, message_id: int, filled: str) -> None:
        recorder = self.world.recorder
        if recorder is not None:
            recorder.put((ev.LOST, self.index, message_id, filled, time.time_ns()))

    # -- what its endpoints see -------------------------------------------------------------------
    def sent(self, data: bytes) -> None:
        """A RobotState left (cycle thread)."""
        recorder = self.world.recorder
        if recorder is not None:
            recorder.put((ev.SENT, self.index, data, time.time_ns()))

    def rejected(self, reason: str, source, data: bytes) -> None:
        """A datagram the endpoint did not hand to the robot, and why."""
        recorder = self.world.recorder
        if recorder is not None:
            recorder.put((ev.REJECTED, self.index, reason, f"{source[0]}:{source[1]}", data,
                          time.time_ns()))

    def tcp(self, service: str, event: str, data: bytes = b"") -> None:
        """A TCP client became the active one ("open"), sent bytes ("data", lock held), or left
        ("close")."""
        recorder = self.world.recorder
        if recorder is not None:
            n, completed = self.world.position()
            recorder.put((ev.TCP, self.index, service, event, data, n, completed,
                          time.time_ns()))

    def reply(self, service: str, data: bytes) -> None:
        """Bytes written to a TCP client (loop thread)."""
        recorder = self.world.recorder
        if recorder is not None:
            recorder.put((ev.REPLY, self.index, service, data, self.world.position()[0],
                          time.time_ns()))

    def tool_state(self, service: str, data: bytes) -> None:
        """A tool's state datagram left (`service`: its service's name; the Hand's
        GripperState, the vacuum gripper's VacuumGripperState)."""
        recorder = self.world.recorder
        if recorder is not None:
            recorder.put((ev.TOOL_STATE, self.index, service, data, time.time_ns()))


class _LogTap(logging.Handler):
    def __init__(self, taps: Taps) -> None:
        super().__init__(logging.DEBUG)
        self.taps = taps

    def emit(self, record: logging.LogRecord) -> None:
        self.taps.log(record)
