"""The recorder's taps: what the server's threads hand it, in the order it happened.

Every tap appends one small tuple to a bounded deque and returns; nothing is encoded, compressed
or written on the cycle thread (writer.py does that on a thread of its own). When the writer
falls behind and the queue is full, events are dropped and counted (the writer logs the count),
never waited for: the 1 kHz cycle keeps its deadline.

Events are kept in the order the core saw them: the cycle thread's taps run in it, the TCP
taps under the simulator's lock, the control API's in the cycle thread's jobs. Each event that
changes the robot records *where* in the cycle sequence it landed: the id of the last released
cycle and whether that cycle had completed (a realtime server releases an idle cycle ahead of
its deadline, so an event can fall between a cycle's release and its completion). That is
what replay needs to apply it at the same point.

A command's fate is recorded with it (on time or late) or with the datagram the endpoint
rejected (and why); a motion cycle that closed without an on-time command (lost) is recorded
by `released`, with how the robot filled it (extrapolated, held, braked, ...): read from the
core's command window and motion once per cycle, and only while recording.
"""

from __future__ import annotations

import collections
import logging
import time
from pathlib import Path

from franka_sim.recording.writer import RecordingWriter

# Event kinds (the tuple's first item).
SENT, COMMAND, REJECTED, TCP, REPLY, CONTROL, POSES, LOG, GRIPPER_STATE, LOST = range(10)

QUEUE_LIMIT = 200_000  # events held at most (~4 s of a 1 kHz motion's traffic and more)
POSE_EVERY = 10  # cycles between two records of the world's free bodies (100 Hz)


class Recorder:
    """Taps for one arm's server, and the writer thread that keeps what they gather."""

    def __init__(self, path: str | Path, metadata: dict, limit: int = QUEUE_LIMIT) -> None:
        self.path = Path(path)
        self._queue: collections.deque = collections.deque()
        self._limit = limit
        self.dropped = 0
        # Opening the file now: a target that cannot be written stops the server at start.
        self._writer = RecordingWriter(self.path, metadata, self._queue, self)
        self._cycle = None
        self._qpos = None
        self._window = None  # the core's command window, as the last cycle left it:
        self._lost = 0  # its lost cycles then,
        self._applied = (None, None)  # and (the motion, its last command applied)
        self._log_tap: logging.Handler | None = None

    # -- lifecycle -------------------------------------------------------------------------------
    def start(self) -> None:
        self._writer.start()

    def stop(self) -> None:
        """Write what is queued and close the file (a valid MCAP with its summary)."""
        if self._log_tap is not None:
            logging.getLogger().removeHandler(self._log_tap)
        self._writer.stop()

    def attach(self, cycle, physics) -> None:
        """Cycle thread, when the robot's cycle is made: what the taps read."""
        self._cycle = cycle
        world = getattr(physics, "world", None)
        if world is not None:
            self._qpos = world.data.qpos  # a view: copied every POSE_EVERY cycles
            self._writer.describe_world(world.model)

    def log_handler(self) -> logging.Handler:
        """A handler that records log lines (removed from the root logger at stop)."""
        self._log_tap = _LogTap(self)
        return self._log_tap

    # -- the taps ----------------------------------------------------------------------------------
    def put(self, event: tuple) -> None:
        if len(self._queue) < self._limit:
            self._queue.append(event)
        else:
            self.dropped += 1

    def position(self) -> tuple[int, bool]:
        """(last released cycle, whether it has completed): where an event lands."""
        cycle = self._cycle
        if cycle is None:
            return 0, True
        n = cycle.core.message_id
        return n, cycle.completed_id == n

    def sent(self, data: bytes) -> None:
        """A RobotState left (cycle thread)."""
        self.put((SENT, data, time.time_ns()))

    def released(self, message_id: int) -> None:
        """A cycle was released (cycle thread): the cycle before it, if it was lost; the free
        bodies, every POSE_EVERY cycles."""
        core = self._cycle.core
        window, motion = core.window, core.motion
        if window is not self._window:  # a Move or a reset: a window of its own, from 0
            self._window, self._lost = window, 0
        if window.lost_total != self._lost:
            self._lost = window.lost_total
            filled = _filled(motion, self._applied)
            self.put((LOST, message_id - 1, filled, time.time_ns()))
        self._applied = (motion, None if motion is None else motion.last_command)
        if message_id % POSE_EVERY == 0 and self._qpos is not None:
            self.put((POSES, message_id, self._qpos.copy(), time.time_ns()))

    def command(self, command, on_time: bool) -> None:
        """The core took a RobotCommand (cycle thread, lock held)."""
        n, completed = self.position()
        self.put((COMMAND, command, on_time, n, completed, time.time_ns()))

    def rejected(self, reason: str, source, data: bytes) -> None:
        """A datagram the endpoint did not hand to the core, and why."""
        self.put((REJECTED, reason, f"{source[0]}:{source[1]}", data, time.time_ns()))

    def tcp(self, service: str, event: str, data: bytes = b"") -> None:
        """A TCP client became the active one ("open"), sent bytes ("data", lock held), or left
        ("close")."""
        n, completed = self.position()
        self.put((TCP, service, event, data, n, completed, time.time_ns()))

    def reply(self, service: str, data: bytes) -> None:
        """Bytes written to a TCP client (loop thread)."""
        self.put((REPLY, service, data, self.position()[0], time.time_ns()))

    def gripper_state(self, data: bytes) -> None:
        self.put((GRIPPER_STATE, data, time.time_ns()))

    def control(self, operation: str, arguments: dict, at: tuple[int, bool], status: int,
                result) -> None:
        """A control API operation ran (cycle thread) at `at` (position() before it ran)."""
        self.put((CONTROL, operation, arguments, status, result, at[0], at[1], time.time_ns()))


EXTRAPOLATED = "extrapolated"


def _filled(motion, applied: tuple) -> str:
    """What the robot made of a lost cycle, as its motion shows after closing the window:
    `extrapolated` (the reference went on at constant acceleration, torques held); `held` (no
    command yet: the motion holds its start); `braked` (past the cycles the robot
    extrapolates); `generated` (an async motion's generator went on); `newer command` (one
    for a cycle not yet published was applied); `motion ended` (the loss ended it)."""
    if motion is None:
        return "motion ended"
    before = applied[1] if applied[0] is motion else None
    if motion.last_command is not before:
        return "newer command"
    if motion.braking:
        return "braked"
    if motion.spec.use_async:
        return "generated"
    if motion.last_command is None:
        return "held"
    return EXTRAPOLATED


class _LogTap(logging.Handler):
    def __init__(self, recorder: Recorder) -> None:
        super().__init__(logging.DEBUG)
        self.recorder = recorder

    def emit(self, record: logging.LogRecord) -> None:
        try:
            message = record.getMessage()
        except Exception:  # noqa: BLE001 - a bad log call must not break the caller
            message = str(record.msg)
        self.recorder.put((LOG, int(record.created * 1e9), record.levelname, record.name,
                           message))
