"""The cycle thread's only part in the web view: now and then, a copy of what it just sent.

The cycle thread never waits for a watcher, takes no lock for one and computes nothing for
one: right after a cycle's states have left (`CycleDriver._send`), at most once per PERIOD
and only while someone watches, it keeps a reference to the states it sent (the bytes the
clients got) and a copy of the world's positions (qpos and the mocap bodies', ~40 floats).
The web thread reads `latest` whenever it draws: one attribute read, atomic under the GIL.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

PERIOD = 0.03  # s between two snapshots: ~33 a second, enough for a 30 Hz view


@dataclass(frozen=True)
class Snapshot:
    time: float  # time.monotonic() when taken
    states: tuple  # each robot's RobotState bytes as sent (None: none sent that cycle)
    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray


class SnapshotTap:
    """Made on the web thread with the world's MjData; `take` runs on the cycle thread."""

    def __init__(self, data) -> None:
        self._data = data
        self.due = 0.0  # the cycle thread takes the next snapshot at or after this time
        self.latest: Snapshot | None = None
        self.taken = 0

    def take(self, states: tuple, now: float) -> None:
        """Cycle thread, right after `states` left (the world is between two steps)."""
        data = self._data
        self.latest = Snapshot(now, tuple(None if s is None else bytes(s) for s in states),
                               data.qpos.copy(), data.mocap_pos.copy(), data.mocap_quat.copy())
        self.due = now + PERIOD
        self.taken += 1

    def take_now(self, states: tuple) -> None:
        """A snapshot now, with each robot's published state (`states`): as a cycle-thread job,
        for a watcher who arrives while the clock is paused and sends nothing."""
        self.take(states, time.monotonic())
