"""A simulator embedded in the test process (its event loop in a thread), so that a test can
reach its endpoints, e.g. to shorten their bounds on dead and hostile peers."""

from __future__ import annotations

import asyncio
import struct
import threading
import time
from contextlib import contextmanager

from franka_sim import FrankaSim
from franka_sim.testing import fresh_loopback_address

ROBOT, GRIPPER = 1337, 1338
CONNECT = {ROBOT: struct.pack("<IIIHH", 0, 0, 16, 10, 40000),
           GRIPPER: struct.pack("<HIIHH", 0, 0, 14, 3, 40001)}


@contextmanager
def serving(host: str | None = None, **bounds):
    """An embedded simulator (on `host`, else a fresh loopback address) whose two TCP
    endpoints take `bounds` (message_deadline, keepalive, max_unsent); yielded once its clock
    runs (an embedded start whose clock never ticks is started again)."""
    host = host or fresh_loopback_address()
    for _ in range(3):
        box: dict = {}
        ready = threading.Event()
        thread = threading.Thread(target=asyncio.run, args=(_serve(host, bounds, box, ready),),
                                  daemon=True)
        thread.start()
        assert ready.wait(60), "the simulator did not start"
        deadline = time.monotonic() + 5
        while box["sim"].core.message_id == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        if box["sim"].core.message_id > 0:
            break
        _stop(box, thread)
    else:
        raise AssertionError("the embedded simulator's clock never ran")
    try:
        yield box["sim"]
    finally:
        _stop(box, thread)


async def _serve(host: str, bounds: dict, box: dict, ready: threading.Event) -> None:
    sim = FrankaSim(host=host)
    for endpoint in (sim.fci, sim.tool_endpoint):
        for name, value in bounds.items():
            setattr(endpoint, name, value)
    async with sim:
        box.update(sim=sim, loop=asyncio.get_running_loop(), stop=asyncio.Event())
        _LOOPS[id(sim)] = box["loop"]
        ready.set()
        await box["stop"].wait()
        del _LOOPS[id(sim)]


_LOOPS: dict[int, asyncio.AbstractEventLoop] = {}


def on_loop(sim, call):
    """call() run on the embedded simulator's event loop (where its endpoints live); its result."""
    async def run():
        return call()
    return asyncio.run_coroutine_threadsafe(run(), _LOOPS[id(sim)]).result(30)


def _stop(box: dict, thread: threading.Thread) -> None:
    box["loop"].call_soon_threadsafe(box["stop"].set)
    thread.join(30)
