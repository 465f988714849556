"""The physics worker's hand-over with the loop: cycles stepped ahead, states sent on the deadline.

A stand-in backend (no MuJoCo) and a real event loop; margins are hundreds of ms so the outcome
does not depend on how busy the machine is. What the tests pin down is ordering: a state
stepped ahead never leaves before its deadline, an overdue one leaves when it is posted, and
the next deadline counts from when a state really left.
"""

from __future__ import annotations

import asyncio
import time

from franka_sim.physics.worker import PhysicsWorker

MARGIN = 1.0  # s between "now" and a deadline in these tests (a busy CI machine)


class Recorder:
    def __init__(self) -> None:
        self.events: list[tuple[str, int, float]] = []

    def mark(self, what: str, cycle: int) -> None:
        self.events.append((what, cycle, time.monotonic()))

    def when(self, what: str, cycle: int) -> float:
        return next(t for w, c, t in self.events if (w, c) == (what, cycle))


async def _started() -> tuple[PhysicsWorker, Recorder, asyncio.AbstractEventLoop]:
    worker = PhysicsWorker(lambda: "backend")
    await worker.start()
    return worker, Recorder(), asyncio.get_running_loop()


def _job(worker, rec, loop, cycle, *, deadline_after, done, wake=lambda: None):
    """A release job for `cycle`; the next deadline comes `deadline_after` s after it is due."""
    def step(backend):
        rec.mark("step", cycle)
        return cycle

    def wake_at(now):
        rec.mark("released", cycle)
        return now + deadline_after

    return PhysicsWorker.release_job(step, (), done, loop, wake_at, wake, cycle)


def test_a_cycle_stepped_ahead_is_sent_on_its_deadline_not_before():
    async def run():
        worker, rec, loop = await _started()
        posted = asyncio.Event()

        def send(data: bytes) -> None:
            rec.mark("sent", int(data))

        def stepped_ahead(cycle):
            assert worker.post(cycle, str(cycle).encode(), send)  # accepted: due later
            posted.set()

        first = asyncio.Event()
        worker.submit_job(_job(worker, rec, loop, 1, deadline_after=MARGIN,
                               done=lambda _: first.set()))
        await first.wait()
        worker.fill_slot(2, _job(worker, rec, loop, 2, deadline_after=MARGIN,
                                 done=stepped_ahead), ahead=True)
        await posted.wait()
        assert rec.when("step", 2) < rec.when("released", 1) + MARGIN  # stepped at once
        while not any(e[:2] == ("released", 2) for e in rec.events):
            await asyncio.sleep(0.01)  # sent, then the next deadline armed
        assert rec.when("sent", 2) >= rec.when("released", 1) + MARGIN  # not before its time
        assert rec.when("released", 2) >= rec.when("sent", 2)  # next deadline from the send
        assert not worker.post(3, b"3", send)  # never stepped ahead: the caller sends it
        await worker.stop()

    asyncio.run(run())


def test_an_overdue_state_leaves_when_posted_and_the_next_deadline_counts_from_then():
    async def run():
        worker, rec, loop = await _started()
        sent = asyncio.Event()

        def send(data: bytes) -> None:
            rec.mark("sent", int(data))
            loop.call_soon_threadsafe(sent.set)

        stepped = asyncio.Event()
        first = asyncio.Event()
        worker.submit_job(_job(worker, rec, loop, 1, deadline_after=0.05,
                               done=lambda _: first.set()))
        await first.wait()
        worker.fill_slot(2, _job(worker, rec, loop, 2, deadline_after=MARGIN,
                                 done=lambda _: stepped.set()), ahead=True)
        await stepped.wait()
        await asyncio.sleep(0.05 + MARGIN)  # the loop is "late": cycle 2's deadline passes
        assert not any(w == "sent" for w, _, _ in rec.events)  # nothing to send yet
        posted_at = time.monotonic()
        assert worker.post(2, b"2", send)
        await sent.wait()
        while not any(e[:2] == ("released", 2) for e in rec.events):
            await asyncio.sleep(0.01)  # the worker arms the next deadline after sending
        assert rec.when("sent", 2) >= posted_at
        assert rec.when("released", 2) >= rec.when("sent", 2)  # no catch-up burst after it
        await worker.stop()

    asyncio.run(run())


def test_a_failed_publish_posts_nothing_and_the_worker_goes_on():
    async def run():
        worker, rec, loop = await _started()
        first, stepped = asyncio.Event(), asyncio.Event()
        worker.submit_job(_job(worker, rec, loop, 1, deadline_after=0.02,
                               done=lambda _: first.set()))
        await first.wait()
        worker.fill_slot(2, _job(worker, rec, loop, 2, deadline_after=0.02,
                                 done=lambda _: stepped.set()), ahead=True)
        await stepped.wait()
        assert worker.post(2, None, lambda data: rec.mark("sent", 2))
        third = asyncio.Event()
        worker.fill_slot(3, _job(worker, rec, loop, 3, deadline_after=0.02,
                                 done=lambda _: third.set()))
        await asyncio.wait_for(third.wait(), 10)  # cycle 3 still runs
        assert not any(w == "sent" for w, _, _ in rec.events)
        await worker.stop()

    asyncio.run(run())
