"""A thread that wakes the event loop at precise monotonic deadlines.

asyncio (and uvloop) timers have about 1 ms granularity, too coarse for a 1 kHz stream. This
thread sleeps with a 1 µs timer slack (Linux `PR_SET_TIMERSLACK`) and then only posts a
callback to the loop; everything else stays on the loop. Each arming carries a token so a
deadline the loop has already moved past (lockstep released the cycle early) is ignored.
"""

from __future__ import annotations

import asyncio
import ctypes
import threading
import time
from typing import Callable

_PR_SET_TIMERSLACK = 29
_CHUNK = 0.002  # re-check arming at least this often while sleeping toward a far deadline


def _tighten_timer_slack() -> None:
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: default slack, coarser but correct
        pass


class DeadlineTimer:
    def __init__(self, loop: asyncio.AbstractEventLoop, callback: Callable[[int], None]) -> None:
        self._loop = loop
        self._callback = callback
        self._cond = threading.Condition()
        self._deadline: float | None = None
        self._token = 0
        self._stopped = False
        self._waiting = False  # blocked on the condition with nothing armed
        self._thread = threading.Thread(target=self._run, name="franka-sim-clock", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def arm(self, deadline: float, token: int) -> None:
        with self._cond:
            self._deadline, self._token = deadline, token
            if self._waiting:  # a sleeping thread re-reads the arming when it wakes anyway
                self._cond.notify()

    def stop(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(1.0)

    def _run(self) -> None:
        _tighten_timer_slack()
        while True:
            with self._cond:
                while self._deadline is None and not self._stopped:
                    self._waiting = True
                    self._cond.wait()
                    self._waiting = False
                if self._stopped:
                    return
                deadline, token = self._deadline, self._token
            remaining = deadline - time.monotonic()
            if remaining > 0:
                time.sleep(min(remaining, _CHUNK))
                if remaining > _CHUNK:
                    continue  # re-read the arming: it may have moved
            with self._cond:
                if self._token != token or self._stopped:
                    continue
                self._deadline = None
            try:
                self._loop.call_soon_threadsafe(self._callback, token)
            except RuntimeError:  # loop closed
                return
