"""The cycle thread as the robot's pacemaker: ticks on their deadlines, wakes, jobs between.

A stand-in backend (no MuJoCo) and a real event loop; the deadlines are a second or more away
so the outcome does not depend on how busy the machine is. What the tests pin down is when the
tick runs: never before the deadline it asked for (unless woken), at once when woken, not at
all once the clock is stopped — and that jobs are still served around it.
"""

from __future__ import annotations

import asyncio
import threading
import time

from franka_sim.server.cycle_thread import CycleThread

MARGIN = 1.0  # s between "now" and a deadline in these tests (a busy CI machine)


class Ticks:
    """A tick that records (due, time, thread) and returns what `plan` says."""

    def __init__(self, plan) -> None:
        self.plan = plan  # plan(n, now) -> next deadline or None
        self.calls: list[tuple[bool, float, str]] = []
        self.changed = threading.Event()

    def __call__(self, backend, due: bool):
        assert backend == "backend"
        now = time.monotonic()
        self.calls.append((due, now, threading.current_thread().name))
        self.changed.set()
        return self.plan(len(self.calls), now)

    async def wait_for(self, n: int, timeout: float = 10.0) -> None:
        deadline = time.monotonic() + timeout
        while len(self.calls) < n:
            assert time.monotonic() < deadline, f"only {len(self.calls)} ticks"
            await asyncio.sleep(0.01)


async def _worker() -> CycleThread:
    worker = CycleThread(lambda: "backend", name="test-physics")
    await worker.start()
    return worker


def test_ticks_run_in_the_worker_on_the_deadline_they_asked_for_not_before():
    async def run():
        worker = await _worker()
        ticks = Ticks(lambda n, now: now + MARGIN if n < 3 else None)
        await worker.run_clock(ticks)
        await ticks.wait_for(3)
        (due1, t1, thread), (due2, t2, _), (due3, t3, _) = ticks.calls
        assert due1 and due2 and due3 and thread == "test-physics"
        assert t2 >= t1 + MARGIN and t3 >= t2 + MARGIN
        await worker.stop()

    asyncio.run(run())


def test_a_wake_runs_the_tick_at_once_and_not_due():
    async def run():
        worker = await _worker()
        far = 30 * MARGIN
        ticks = Ticks(lambda n, now: now + far if n == 1 else ticks.calls[0][1] + far)
        await worker.run_clock(ticks)
        await ticks.wait_for(1)
        worker.wake()
        await ticks.wait_for(2)
        (_, t1, _), (due2, t2, _) = ticks.calls
        assert not due2 and t2 < t1 + far
        await worker.stop()

    asyncio.run(run())


def test_a_clock_without_a_deadline_waits_for_a_wake():
    async def run():
        worker = await _worker()
        ticks = Ticks(lambda n, now: None)
        await worker.run_clock(ticks)
        await ticks.wait_for(1)
        assert await worker.call(lambda backend: backend) == "backend"  # jobs still run
        await asyncio.sleep(0.2)
        assert len(ticks.calls) == 1
        worker.wake()
        await ticks.wait_for(2)
        await worker.stop()

    asyncio.run(run())


def test_no_tick_runs_once_the_clock_is_stopped():
    async def run():
        worker = await _worker()
        ticks = Ticks(lambda n, now: now + 0.01)  # a fast clock
        await worker.run_clock(ticks)
        await ticks.wait_for(3)
        await worker.run_clock(None)
        stopped_at = len(ticks.calls)
        worker.wake()
        await asyncio.sleep(0.2)
        assert len(ticks.calls) == stopped_at
        await worker.stop()

    asyncio.run(run())


def test_a_failing_tick_stops_the_clock_and_jobs_go_on():
    async def run():
        worker = await _worker()

        def plan(n, now):
            raise RuntimeError("a broken cycle")

        ticks = Ticks(plan)
        await worker.run_clock(ticks)
        await ticks.wait_for(1)
        worker.wake()
        assert await worker.call(lambda backend: 42) == 42
        await asyncio.sleep(0.1)
        assert len(ticks.calls) == 1
        await worker.stop()

    asyncio.run(run())


def _udp_pair():
    import socket

    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.setblocking(False)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender.connect(receiver.getsockname())
    return receiver, sender


FAR = 30 * MARGIN


async def _first_tick_watching(worker, sock) -> Ticks:
    """A clock whose first tick watches `sock`; every deadline is FAR after that tick."""
    def plan(n, now):
        if n == 1:
            worker.watch(sock)  # ticks run in the worker: the watch is theirs to set
        return ticks.calls[0][1] + FAR

    ticks = Ticks(plan)
    await worker.run_clock(ticks)
    await ticks.wait_for(1)
    return ticks


def test_data_on_a_watched_socket_runs_the_tick_at_once_and_not_due():
    """A lockstep cycle waits for its answer this way: the datagram itself wakes the worker."""
    async def run():
        worker = await _worker()
        receiver, sender = _udp_pair()
        ticks = await _first_tick_watching(worker, receiver)
        sender.send(b"answer")
        await ticks.wait_for(2)
        (_, t1, _), (due2, t2, thread) = ticks.calls
        assert not due2 and t2 < t1 + FAR and thread == "test-physics"
        assert receiver.recv(64) == b"answer"  # the worker only woke the tick; it read nothing
        await worker.stop()
        receiver.close()
        sender.close()

    asyncio.run(run())


def test_a_watch_holds_only_until_the_next_tick():
    async def run():
        worker = await _worker()
        receiver, sender = _udp_pair()
        ticks = await _first_tick_watching(worker, receiver)
        worker.wake()  # the second tick does not watch again
        await ticks.wait_for(2)
        sender.send(b"late")
        assert await worker.call(lambda backend: backend) == "backend"  # jobs still run
        await asyncio.sleep(0.2)
        assert len(ticks.calls) == 2
        await worker.stop()
        receiver.close()
        sender.close()

    asyncio.run(run())
