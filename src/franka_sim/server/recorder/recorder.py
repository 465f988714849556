"""A recording under way: the queue the taps fill and the writer thread that drains it.

Every tap appends one small tuple to a bounded deque and returns; nothing is encoded, compressed
or written on the cycle thread (writer.py does that on a thread of its own). When the writer
falls behind and the queue is full, events are dropped and counted (the writer logs the count),
never waited for: the 1 kHz cycle keeps its deadline.
"""

from __future__ import annotations

import collections
import logging
from pathlib import Path

from franka_sim.server.recorder.writer import RecordingWriter

log = logging.getLogger(__name__)

QUEUE_LIMIT = 200_000  # events held at most (~4 s of a 1 kHz motion's traffic and more)


class Recorder:
    """Writes what the taps hand it to `path` (OSError at once if it cannot be written);
    `robots`: the robots' names by index (their channels' prefixes)."""

    def __init__(self, path: str | Path, metadata: dict, robots: list[str],
                 limit: int = QUEUE_LIMIT) -> None:
        self.path = Path(path)
        self._queue: collections.deque = collections.deque()
        self._limit = limit
        self.dropped = 0
        self._stopped = False
        self.started = False
        # Opening the file now: a target that cannot be written stops the server at start.
        # (The file that was there stays until the recording starts: target.py.)
        self._writer = RecordingWriter(self.path, metadata, robots, self._queue, self)

    def describe_world(self, free_bodies: list[tuple[str, int]]) -> None:
        """(name, qpos address) of the world's free bodies, whose poses the records of qpos
        hold (before the first is written)."""
        self._writer.free_bodies = free_bodies

    def start(self) -> None:
        """Its file takes the target's place, and what is queued is written (OSError: the
        target cannot be replaced: another process records to it since)."""
        self._writer.start()
        self.started = True

    def stop(self) -> None:
        """Write what is queued and close the file (a valid MCAP with its summary); once. A
        recording never started leaves nothing, the target as it was."""
        if not self._stopped:
            self._stopped = True
            if self.started:
                self._writer.stop()
            else:
                self._writer.abandon()

    @property
    def failure(self) -> OSError | None:
        """The write that stopped this recording (None while it records)."""
        return self._writer.failure

    def put(self, event: tuple) -> None:
        if len(self._queue) < self._limit:
            if self._writer.failure is None:  # (a stopped recording takes nothing more)
                self._queue.append(event)
        else:
            self.dropped += 1
