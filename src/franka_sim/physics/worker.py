"""The one thread that owns the MuJoCo data, fed through a queue — and the robot's pacemaker.

MuJoCo steps in this thread so the event loop never blocks on physics; every access to the
backend (a step, a model query, a parameter change) is a job on the same queue, so the MjData
is only ever touched by one thread and jobs run in the order they were submitted. Results come
back to the loop with `call_soon_threadsafe` — a callback, not a coroutine, because this is on
the 1 kHz path and a callback costs less than awaiting a future.

The thread also keeps the 1 ms deadlines: after a step it can be told when the next cycle is
due, and its wait for the next job is that sleep (timer slack 1 µs, Linux `PR_SET_TIMERSLACK`).
asyncio and uvloop timers have ~1 ms granularity, too coarse for a 1 kHz stream. When the
deadline comes, the worker runs the job the loop left in the *slot* for that cycle (the loop
fills it as soon as it knows the cycle's command, usually long before the deadline), so a cycle
costs one hand-over back to the loop; only with an empty slot does it wake the loop to decide.
"""

from __future__ import annotations

import asyncio
import ctypes
import logging
import queue
import threading
import time
from typing import Any, Callable

log = logging.getLogger(__name__)

_STOP = object()
_PR_SET_TIMERSLACK = 29


def _tighten_timer_slack() -> None:
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: default slack, coarser but correct
        pass


class PhysicsWorker:
    def __init__(self, make_backend: Callable[[], Any], name: str = "franka-sim-physics") -> None:
        self._make_backend = make_backend
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._backend: Any = None
        self._deadline: float | None = None  # only touched by the worker thread
        self._wake: tuple[Callable[[], None], asyncio.AbstractEventLoop] | None = None
        self._slot: tuple[int, tuple] | None = None  # (cycle, job) the loop prepared
        self._cycle = 0  # the last cycle a release job ran for

    def fill_slot(self, cycle: int, job: tuple) -> None:
        """The release job for `cycle`, to run at its deadline (a stale cycle is ignored)."""
        self._slot = (cycle, job)  # one reference store: atomic, no lock or wake needed

    async def start(self) -> None:
        """Build the backend inside the worker thread (MjData must live where it steps)."""
        self._thread.start()
        await self.call(lambda backend: None)

    def submit(self, fn: Callable, args: tuple, done: Callable[[Any], None],
               loop: asyncio.AbstractEventLoop) -> None:
        """Run fn(backend, *args) in the worker; call done(result) on the loop afterwards."""
        self._jobs.put((fn, args, done, loop, None, None, None))

    def submit_job(self, job: tuple) -> None:
        """Queue a cycle release made by `release_job`, to run as soon as the worker is free.

        A release cancels any pending wake-up; after it the worker calls `wake_at(now)` (in its
        own thread) for the next deadline, and when that comes runs the slot's job for the next
        cycle, or with none calls `wake()` on the loop.
        """
        self._jobs.put(job)

    @staticmethod
    def release_job(fn: Callable, args: tuple, done: Callable[[Any], None],
                    loop: asyncio.AbstractEventLoop, wake_at, wake, cycle: int) -> tuple:
        """A job tuple for `fill_slot`, shaped as `submit` queues it."""
        return (fn, args, done, loop, wake_at, wake, cycle)

    async def call(self, fn: Callable, *args) -> Any:
        """Run fn(backend, *args) in the worker and await its result (not for the hot path)."""
        loop = asyncio.get_running_loop()
        fut = loop.create_future()

        def done(result):
            if fut.done():
                return
            if isinstance(result, BaseException):
                fut.set_exception(result)
            else:
                fut.set_result(result)

        self.submit(fn, args, done, loop)
        return await fut

    async def stop(self) -> None:
        if self._thread.is_alive():
            self._jobs.put(_STOP)
            await asyncio.get_running_loop().run_in_executor(None, self._thread.join, 2.0)

    def _next_job(self):
        """The next job, or None when the armed deadline came first (the loop has been woken)."""
        while True:
            if self._deadline is None:
                return self._jobs.get()
            remaining = self._deadline - time.monotonic()
            try:
                return self._jobs.get(timeout=remaining) if remaining > 0 else self._jobs.get_nowait()
            except queue.Empty:
                slot, self._slot = self._slot, None
                if slot is not None and slot[0] == self._cycle + 1:
                    return slot[1]  # the loop already decided this cycle
                wake, loop = self._wake
                self._deadline = self._wake = None
                try:
                    loop.call_soon_threadsafe(wake)
                except RuntimeError:  # loop closed during shutdown
                    return _STOP

    def _run(self) -> None:
        _tighten_timer_slack()
        try:
            self._backend = self._make_backend()
        except BaseException as exc:  # reported to whoever awaits start()
            self._backend = exc
        while True:
            job = self._next_job()
            if job is _STOP:
                return
            fn, args, done, loop, wake_at, wake, cycle = job
            if wake_at is not None:
                self._deadline = self._wake = None  # this job is the release the wake was for
                self._cycle = cycle
            if isinstance(self._backend, BaseException):
                result: Any = self._backend
            else:
                try:
                    result = fn(self._backend, *args)
                except Exception as exc:  # noqa: BLE001 - handed back to the caller
                    log.exception("physics job failed")
                    result = exc
            if wake_at is not None:
                deadline = wake_at(time.monotonic())
                if deadline is not None:
                    self._deadline, self._wake = deadline, (wake, loop)
            try:
                loop.call_soon_threadsafe(done, result)
            except RuntimeError:  # loop already closed during shutdown
                return
