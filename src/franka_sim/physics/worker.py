"""The one thread that owns the MuJoCo data, fed through a queue.

MuJoCo steps in this thread so the event loop never blocks on physics; every access to the
backend (a step, a model query, a parameter change) is a job on the same queue, so the MjData
is only ever touched by one thread and jobs run in the order they were submitted. Results come
back to the loop with `call_soon_threadsafe` — a callback, not a coroutine, because this is on
the 1 kHz path and a callback costs less than awaiting a future.
"""

from __future__ import annotations

import asyncio
import logging
import queue
import threading
from typing import Any, Callable

log = logging.getLogger(__name__)

_STOP = object()


class PhysicsWorker:
    def __init__(self, make_backend: Callable[[], Any], name: str = "franka-sim-physics") -> None:
        self._make_backend = make_backend
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._backend: Any = None

    async def start(self) -> None:
        """Build the backend inside the worker thread (MjData must live where it steps)."""
        self._thread.start()
        await self.call(lambda backend: None)

    def submit(self, fn: Callable, args: tuple, done: Callable[[Any], None],
               loop: asyncio.AbstractEventLoop) -> None:
        """Run fn(backend, *args) in the worker; call done(result) on the loop afterwards."""
        self._jobs.put((fn, args, done, loop))

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

    def _run(self) -> None:
        try:
            self._backend = self._make_backend()
        except BaseException as exc:  # reported to whoever awaits start()
            self._backend = exc
        while True:
            job = self._jobs.get()
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
