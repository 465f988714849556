"""The cycle thread: the one thread that owns the MuJoCo data, and the robot's pacemaker.

MuJoCo steps in this thread so the event loop never blocks on physics; every access to the
backend (a cycle, a model query, a parameter change) runs here, so the MjData is only ever
touched by one thread and jobs run in the order they were submitted. Results of jobs come back
to the loop with `call_soon_threadsafe` (a callback, cheaper than awaiting a future).

The thread also keeps the robot's clock. Given a *tick* (`run_clock`), it calls it at the
deadline the previous tick returned; its wait for the next job is that sleep (timer slack 1 µs,
Linux `PR_SET_TIMERSLACK`), because asyncio and uvloop timers have ~1 ms granularity, too coarse
for a 1 kHz stream. A whole cycle — the commands that arrived, the step, the state packed and
sent — is one tick in this thread: one wake-up per cycle instead of a round trip through the
loop, which on a 2-core VM cost more than the cycle's own work (server/cycle_driver.py says
what a tick does). `wake()` runs the tick at once without waiting for the deadline (a paused
clock: a client came). A tick may also ask to be run as soon as a socket has data (`watch`,
until the next tick): a lockstep cycle waits for its answer that way, in this thread's own
wait, so no other thread wakes for a datagram (the event loop that did cost ~10 % of lockstep
speed, taking the interpreter from the thread that runs the cycle).

The wait is one `select` on a socket pair (jobs and wakes write a byte to it) and the watched
socket, with the deadline as its timeout.
"""

from __future__ import annotations

import asyncio
import collections
import ctypes
import logging
import select
import socket
import time
from typing import Any, Callable

from franka_sim.log_names import ContextThread

log = logging.getLogger(__name__)

_STOP = object()
_WAKE = object()  # run the tick now, ahead of its deadline
_PR_SET_NAME = 15
_PR_SET_TIMERSLACK = 29
OS_THREAD_NAME = b"fsim-cycle"  # what top, ps -L and /proc show for this thread

# tick(backend, due) -> the monotonic time of the next tick, or None: only when woken.
# `due`: the deadline came (False: woken early; the tick decides whether that releases a cycle).
Tick = Callable[[Any, bool], "float | None"]


def _tune_this_thread() -> None:
    """1 µs timer slack (precise deadlines) and a name ps and top show."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
        prctl(_PR_SET_TIMERSLACK, 1, 0, 0, 0)
        prctl(_PR_SET_NAME, ctypes.c_char_p(OS_THREAD_NAME), 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: default slack, coarser but correct
        pass


class CycleThread:
    def __init__(self, make_backend: Callable[[], Any], name: str = "franka-sim-cycle") -> None:
        self._make_backend = make_backend
        self._jobs: collections.deque = collections.deque()
        # A byte on _bell after each job: what the worker's select wakes on.
        self._doorbell, self._bell = socket.socketpair()
        for end in (self._doorbell, self._bell):
            end.setblocking(False)
        self._thread = ContextThread(target=self._run, name=name, daemon=True)
        self._backend: Any = None
        # Only touched by the worker thread:
        self._tick: Tick | None = None
        self._deadline: float | None = None
        self._watched: socket.socket | tuple[socket.socket, ...] | None = None
        # Why the clock stopped for good (a tick raised), and whom to tell, on their loop.
        self.failure: str | None = None
        self._on_failure: tuple[Callable[[str], None], asyncio.AbstractEventLoop] | None = None

    async def start(self, on_failure: Callable[[str], None] | None = None) -> None:
        """Build the backend inside the worker thread (MjData must live where it steps).
        `on_failure(reason)` is called on this loop if the clock stops for good."""
        if on_failure is not None:
            self._on_failure = (on_failure, asyncio.get_running_loop())
        self._thread.start()
        try:
            await self.call(lambda backend: None)
        except BaseException:  # the world could not be built: the thread ends with the start
            await self.stop()
            raise

    def submit(self, fn: Callable, args: tuple, done: Callable[[Any], None],
               loop: asyncio.AbstractEventLoop) -> None:
        """Run fn(backend, *args) in the worker; call done(result) on the loop afterwards."""
        self._put((fn, args, done, loop))

    def _put(self, job) -> None:
        self._jobs.append(job)
        try:
            self._bell.send(b"\0")
        except OSError:  # the pair's buffer is full (wake-ups are pending), or it is stopped
            pass

    @property
    def jobs_waiting(self) -> bool:
        """A job (or a wake) is queued: a tick that would run on should return first."""
        return bool(self._jobs)

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

    async def run_clock(self, tick: Tick | None) -> None:
        """Start ticking (the first tick at once), or with None stop; returns once the worker
        took it, so no tick of the old clock runs after this."""
        def swap(backend):
            self._tick = tick
            self._deadline = time.monotonic() if tick is not None else None
            self._watched = None
        await self.call(swap)

    def wake(self) -> None:
        """Run the tick now (any thread); `due` is False."""
        self._put(_WAKE)

    def watch(self, sock: socket.socket | tuple[socket.socket, ...] | None) -> None:
        """From a tick: run the next tick (`due` False) as soon as `sock` (or one of several:
        a world of several arms) has data, if that comes before the deadline. Holds until the
        next tick runs."""
        self._watched = sock

    async def stop(self) -> None:
        if self._thread.is_alive():
            self._put(_STOP)
            await asyncio.get_running_loop().run_in_executor(None, self._thread.join, 2.0)
        if not self._thread.is_alive():  # (a thread stuck in a job keeps its doorbell)
            self._doorbell.close()
            self._bell.close()

    def _next_job(self) -> Any:
        """The next job (_WAKE when the watched socket has data); None when the deadline came
        first."""
        jobs, doorbell = self._jobs, self._doorbell
        while not jobs:
            timeout = None
            if self._deadline is not None:
                timeout = self._deadline - time.monotonic()
                if timeout <= 0:
                    return None
            watched = self._watched
            if isinstance(watched, tuple):
                watched = tuple(sock for sock in watched if sock.fileno() >= 0)
                ready = select.select((doorbell, *watched), (), (), timeout)[0]
                if ready and doorbell not in ready:
                    return _WAKE
            elif watched is not None and watched.fileno() >= 0:
                ready = select.select((doorbell, watched), (), (), timeout)[0]
                if watched in ready and doorbell not in ready:
                    return _WAKE
            else:
                ready = select.select((doorbell,), (), (), timeout)[0]
            if not ready:
                return None
            if doorbell in ready:
                try:
                    doorbell.recv(4096)  # the jobs behind these bytes are in the deque
                except BlockingIOError:
                    pass
        return jobs.popleft()

    def _ticked(self, due: bool) -> None:
        tick = self._tick
        self._watched = None  # a watch holds until the next tick (which may set it again)
        if tick is None:
            return
        try:
            self._deadline = tick(self._backend, due)
        except Exception as exc:  # noqa: BLE001 - the clock stops; jobs are still served
            log.exception("the cycle failed; the clock stops")
            self._tick = self._deadline = None
            self._failed(f"the cycle failed: {type(exc).__name__}: {exc}")

    def _failed(self, reason: str) -> None:
        """The clock stopped for good: say so to whoever asked to be told."""
        self.failure = reason
        if self._on_failure is not None:
            callback, loop = self._on_failure
            try:
                loop.call_soon_threadsafe(callback, reason)
            except RuntimeError:  # loop already closed during shutdown
                pass

    def _run(self) -> None:
        _tune_this_thread()
        try:
            self._backend = self._make_backend()
        except BaseException as exc:  # reported to whoever awaits start()
            self._backend = exc
        try:
            self._serve()
        except BaseException as exc:  # the thread itself dies: nothing steps any more
            log.exception("the cycle thread failed")
            self._failed(f"the cycle thread failed: {type(exc).__name__}: {exc}")

    def _serve(self) -> None:
        """Ticks and jobs until stopped."""
        while True:
            job = self._next_job()
            if job is None or job is _WAKE:
                self._ticked(due=job is None)
                continue
            if job is _STOP:
                return
            fn, args, done, loop = job
            if isinstance(self._backend, BaseException):
                result: Any = self._backend
            else:
                try:
                    result = fn(self._backend, *args)
                except Exception as exc:  # noqa: BLE001 - handed back to the caller
                    log.exception("physics job failed")
                    result = exc
            try:
                loop.call_soon_threadsafe(done, result)
            except RuntimeError:  # loop already closed during shutdown
                return
