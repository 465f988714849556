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

Ahead of time. A slot filled with `ahead=True` (the loop knows the cycle's command early: the
arm is idle) is stepped at once instead of at its deadline; the loop publishes the state and
`post`s the bytes back, and the worker sends them on the deadline itself. The state then
leaves on time to within this thread's wake-up, not after a step and a hand-over through the
loop. Sending a datagram from this thread is the one thing it does with a socket: the loop
still owns the endpoint and gives it a send function that is safe to call from here.
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
_SLOT = object()  # wake-up: a slot was filled that may be stepped ahead of its deadline
_POSTED = object()  # wake-up: the state of an overdue cycle stepped ahead was posted
_PR_SET_NAME = 15
_PR_SET_TIMERSLACK = 29
OS_THREAD_NAME = b"fsim-physics"  # what top, ps -L and /proc show for this thread


def _tune_this_thread() -> None:
    """1 µs timer slack (precise deadlines) and a name ps and top show."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
        prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)
        prctl(_PR_SET_NAME, ctypes.c_char_p(OS_THREAD_NAME), 0, 0, 0)
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
        # A cycle stepped ahead, due at self._deadline: (cycle, wake_at, wake, loop); and the
        # state the loop posted for it. Both change under _box (loop thread vs this one).
        self._ahead: tuple | None = None
        self._outbox: tuple[int, bytes | None, Callable[[bytes], None]] | None = None
        self._overdue = False  # its deadline passed before the state was posted
        self._box = threading.Lock()

    def fill_slot(self, cycle: int, job: tuple, *, ahead: bool = False) -> None:
        """The release job for `cycle`, to run at its deadline (a stale cycle is ignored), or
        with `ahead` as soon as the worker is free, its state sent on the deadline (`post`)."""
        self._slot = (cycle, job)  # one reference store: atomic, no lock needed
        if ahead and self._ahead is None:  # (with one pending, the worker takes it on sending)
            self._jobs.put(_SLOT)

    def post(self, cycle: int, data: bytes | None, send: Callable[[bytes], None]) -> bool:
        """Send `data`, the state of `cycle`, on its deadline with `send` (from this thread);
        None: nothing to send (publishing failed), go on. Overdue, it is sent at once, and the
        next deadline counts from then, so states never bunch up.

        False: `cycle` was not stepped ahead — the caller sends it.
        """
        with self._box:
            if self._ahead is None or self._ahead[0] != cycle:
                return False
            self._outbox = (cycle, data, send)
            if self._overdue:
                self._jobs.put(_POSTED)
            return True

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

    def _next_job(self) -> tuple[Any, bool]:
        """The next job and whether it runs ahead of its deadline."""
        while True:
            if self._deadline is None:
                job = self._jobs.get()
            else:
                remaining = self._deadline - time.monotonic()
                try:
                    job = (self._jobs.get(timeout=remaining) if remaining > 0
                           else self._jobs.get_nowait())
                except queue.Empty:
                    job = self._due()
                    if job is None:
                        continue
                    return job
            if job is _SLOT:
                job = self._ahead_job()
                if job is None:
                    continue
                return job
            if job is _POSTED:
                job = self._send_ahead()
                if job is None:
                    continue
                return job
            return job, False

    def _ahead_job(self) -> tuple[tuple, bool] | None:
        """The slot's job, if it is the next cycle and may run before its deadline now."""
        slot = self._slot
        if (slot is None or slot[0] != self._cycle + 1 or self._ahead is not None
                or self._deadline is None):
            return None
        self._slot = None
        return slot[1], True

    def _due(self):
        """The armed deadline came: send the state stepped ahead, or release the cycle.

        Returns (job, ahead), None to wait on, or _STOP."""
        if self._ahead is not None:
            return self._send_ahead()
        slot, self._slot = self._slot, None
        if slot is not None and slot[0] == self._cycle + 1:
            return slot[1], False  # the loop already decided this cycle
        wake, loop = self._wake
        self._deadline = self._wake = None
        try:
            loop.call_soon_threadsafe(wake)
        except RuntimeError:  # loop closed during shutdown
            return _STOP
        return None

    def _send_ahead(self) -> tuple[tuple, bool] | None:
        """Send the cycle stepped ahead (or, not posted yet, wait for it), arm the next one."""
        with self._box:
            box, ahead = self._outbox, self._ahead
            if box is None:  # the loop has not packed it yet: post() wakes us
                self._overdue, self._deadline = True, None
                return None
            self._outbox = self._ahead = None
            self._overdue = False
            if box[1] is not None:
                box[2](box[1])
        _cycle, wake_at, wake, loop = ahead
        self._deadline = self._wake = None
        self._arm(wake_at, wake, loop)
        return self._ahead_job()  # the next cycle may be decided already

    def _arm(self, wake_at, wake, loop) -> None:
        deadline = wake_at(time.monotonic())
        if deadline is not None:
            self._deadline, self._wake = deadline, (wake, loop)

    def _run(self) -> None:
        _tune_this_thread()
        try:
            self._backend = self._make_backend()
        except BaseException as exc:  # reported to whoever awaits start()
            self._backend = exc
        while True:
            job = self._next_job()
            if job is _STOP:
                return
            job, ahead = job
            if job is _STOP:
                return
            fn, args, done, loop, wake_at, wake, cycle = job
            if ahead:  # the deadline stays armed: it is when this cycle's state is sent
                with self._box:
                    self._ahead = (cycle, wake_at, wake, loop)
                self._cycle = cycle
            elif wake_at is not None:
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
            if wake_at is not None and not ahead:
                self._arm(wake_at, wake, loop)
            try:
                loop.call_soon_threadsafe(done, result)
            except RuntimeError:  # loop already closed during shutdown
                return
