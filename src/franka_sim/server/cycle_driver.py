"""The cycle thread's side of the clock: the thin adapter between server/clock.py (the policy,
sans-IO) and the threads, sockets and event loop.

Each tick of the cycle thread reads the commands that arrived on every robot's UDP socket and
hands them to the world's cycle (a straight line: datagrams → commands → `Cycle.receive`),
then lets the clock release what is due, sending its states on the robots' sockets. One
wake-up per cycle: on a 2-core VM every extra hand-over between threads cost more CPU than the
cycle's own work. In lockstep the tick then reads the sockets for the answer for a moment
(`_await_answer`) before it goes to sleep watching them (CycleThread.watch). The robots' cores
and tools are shared with the loop's TCP endpoints, so they are only touched with `lock` held:
the tick holds it for its cycles, the endpoints for each request.

Replies go out on the loop once the state they follow has left: a request's replies after the
first state published after it (`after_next_state`), a cycle's own (a Move's end, a recovery)
after that cycle's state. libfranka reads the newest queued state after a reply, which must
show what the reply says.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from typing import Callable, Sequence

from franka_sim.server.clock import Clock, ClockWatcher
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server import read_probe
from franka_sim.server.read_probe import probe_for, too_slow
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

LOCKSTEP_SPIN = 300e-6  # s a lockstep tick keeps reading the sockets before it sleeps
READ_POLL = 250e-6  # s between looks at a client's socket while the clock awaits its read


class CycleDriver:
    """Runs the world's cycle (`make_cycle(physics)`, built in the cycle thread) on `thread`.

    `deliver(replies, clients)`, on the loop: write a completed world cycle's replies to the
    `clients()` connected when it completed (asked in the cycle thread, lock held); `has_client()`:
    a client is connected to some robot or tool; `watcher`: who keeps count of what the clock
    does (Clock.watcher)."""

    def __init__(self, make_cycle: Callable, thread: CycleThread, lock: threading.Lock, *,
                 lockstep: bool, deliver: Callable, clients: Callable,
                 has_client: Callable[[], bool], watcher: ClockWatcher,
                 find_probe: Callable = probe_for) -> None:
        self.make_cycle, self.thread, self.lock = make_cycle, thread, lock
        self.lockstep, self.deliver, self.has_client = lockstep, deliver, has_client
        self.clients = clients
        self.watcher = watcher
        # find_probe(target): whether a client at `target` has read its states
        # (server/read_probe.py), None where that cannot be seen; each robot's, by its client.
        self.find_probe = find_probe
        self._probes: dict[int, tuple] = {}  # robot: (its client's target, its probe)
        self.endpoints: tuple = ()  # each robot's UdpEndpoint, by robot index
        self.cycle = None
        self.clock: Clock | None = None
        self.faults = None  # server/network_faults.py NetworkFaults while faults are injected
        # web/snapshots.py SnapshotTap while someone watches the web view: a copy of what was
        # sent, at most every 30 ms (one `if` per send otherwise).
        self.snapshots = None
        self._sockets: tuple = ()
        self._awaiting: list[tuple[int, Callable[[], None]]] = []  # loop: (cycle, deliver)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._running = False
        self._busy = 0  # server_busy's count
        self._stalls = 0  # the pacer's stalls said so far

    # -- the loop's side -------------------------------------------------------------------------
    async def start(self, endpoints: Sequence) -> None:
        """Run the clock, reading commands from and sending states on `endpoints` (each
        robot's UdpEndpoint, by robot index: their `read`, `send_state`, `sock`)."""
        self._loop = asyncio.get_running_loop()
        self.endpoints = tuple(endpoints)
        if self.cycle is None:
            self.cycle = await self.thread.call(self.make_cycle)
            self.clock = Clock(self.cycle, lockstep=self.lockstep, send=self._send,
                               post=self._post, has_client=self.has_client,
                               reads_seen=self._reads_seen, unseen=self._unseen)
            self.clock.watcher = self.watcher
            self.clock.server_busy = self._busy
        self._sockets = tuple(endpoint.sock for endpoint in self.endpoints)
        self._running = True
        await self.thread.run_clock(self._tick)

    async def stop(self) -> None:
        self._running = False
        await self.thread.run_clock(None)  # no tick runs after this

    @property
    def paused(self) -> bool:
        return self.clock is not None and self.clock.paused

    def resume(self) -> None:
        """A client arrived: a paused clock starts again at once."""
        self.thread.wake()

    def client_event(self, disturbing: bool = True) -> None:
        """A TCP request (robot or tool) or a client's disconnect, lock held
        (Clock.client_event)."""
        self.clock.client_event(disturbing)
        if self.lockstep:
            self.thread.wake()

    def keep_running(self, cycles: int = 0) -> None:
        """Cycle thread: the world was changed from outside (Clock.world_changed)."""
        self.clock.world_changed(cycles)
        if self.lockstep or self.clock.paused:
            self.thread.wake()

    def server_busy(self, busy: bool) -> None:
        """Lockstep: the server keeps its clients waiting (`busy`) or no longer; a cycle's
        window does not run out meanwhile (Clock.server_busy). From the loop."""
        with self.lock:
            self._busy += 1 if busy else -1
            if self.clock is not None:
                self.clock.server_busy = self._busy

    def withdraw_prepared(self) -> int | None:
        """Cycle thread, lock held, before a reset (Clock.withdraw_prepared)."""
        return self.clock.withdraw_prepared()

    def after_next_state(self, deliver: Callable[[], None]) -> bool:
        """Call `deliver` (a request's replies) once the first state published after now has
        been sent; False while no state is coming (stopped, paused): deliver now. Lock held."""
        if not self._running or self.clock.paused:
            return False
        self._awaiting.append((self.cycle.message_id + 1, deliver))
        return True

    def _sent(self, message_id: int, replies, clients) -> None:
        """The state of `message_id` has left: the replies that waited for it, then its own."""
        awaiting = self._awaiting
        while awaiting and awaiting[0][0] <= message_id:
            awaiting.pop(0)[1]()
        if replies and self._running:
            self.deliver(replies, clients)

    # -- the cycle thread's side -----------------------------------------------------------------
    def _send(self, states: tuple) -> float:
        for endpoint, state in zip(self.endpoints, states):
            if state is not None:
                endpoint.send_state(state)
        now = time.monotonic()
        tap = self.snapshots
        if tap is not None and now >= tap.due:
            tap.take(states, now)
        return now

    def _post(self, message_id: int, replies) -> None:
        if replies or self._awaiting:
            try:
                self._loop.call_soon_threadsafe(self._sent, message_id, replies,
                                                self.clients() if replies else None)
            except RuntimeError:  # loop closed during shutdown
                pass

    def _tick(self, _physics, due: bool) -> float | None:
        try:
            if due and self.clock.awaits_read is not None:
                due = self._look_for_read()
                if not due:  # (an answer, or an event, still wakes the tick at once)
                    self.thread.watch(self._sockets)
                    return self._looking(self.clock.deadline)
            with self.lock:
                deadline = self._tick_locked(due)
            while self.clock.answer_awaited:
                # A control-API job waits for this tick: let it run before the next cycle (a
                # client answering within the spin would otherwise keep the tick, and the
                # job, waiting for the whole motion).
                if self.thread.jobs_waiting or not self._await_answer():
                    self.thread.watch(self._sockets)  # (the answer, handed to the cycle, may
                    break  # have ended the motion: it was awaited)
                with self.lock:
                    deadline = self._tick_locked(False, answered=True, awaited=True)
            if not self.lockstep and self.clock.pacer.stalls != self._stalls:
                self._stalled()
            return deadline if self.clock.awaits_read is None else self._looking(deadline)
        except BaseException:
            self._running = False  # the cycle thread logs it and stops the clock
            raise

    def _stalled(self) -> None:
        """The realtime clock fell behind the wall clock and went on from now (pacing.py):
        said, thinned, since a client sees nothing of it but a slower robot."""
        pacer = self.clock.pacer
        for count in range(self._stalls + 1, pacer.stalls + 1):
            if worth_logging(count):
                log.warning("the realtime clock fell behind the wall clock (the cycle thread was "
                            "not run in time, or its cycles took longer than 1 ms): the robot's "
                            "time runs slower than the wall clock (stall %d, %.3f s "
                            "behind in all)", count, pacer.behind)
        self._stalls = pacer.stalls

    def _tick_locked(self, due: bool, answered: bool = False,
                     awaited: bool | None = None) -> float | None:
        clock = self.clock
        if awaited is None:
            awaited = clock.answer_awaited  # (before the answer: it may end the motion)
        prepared = clock.prepared is not None  # an idle cycle released ahead: it goes first
        # At every deadline, idle ones too (a stray datagram is counted and logged within a
        # cycle); in lockstep also while the answer is awaited (_await_answer).
        if due and not prepared:
            answered = self._read() or answered
        if self.faults is not None:
            answered = self.faults.answered(self.cycle)
        deadline = clock.tick(due, answered, awaited)
        if due and prepared:  # no command can answer an idle state: what came
            self._read()  # (strays, junk) is read once the state has left
        return deadline

    def _unseen(self, since: int) -> bool:
        """Whether a connected client was sent no state of cycle `since` or later (lock held):
        an injected fault dropped or holds them."""
        return any(link is not None and endpoint.target is not None and link.newest < since
                   for endpoint in self.endpoints for link in (endpoint.faults,))

    def _reads_seen(self, robot: int) -> bool:
        """Whether robot `robot`'s client's reads can be seen (lock held): a client on this
        host, states reaching it straight (no faults injected)."""
        return self.endpoints[robot].faults is None and self._probe(robot) is not None

    def _probe(self, robot: int):
        target = self.endpoints[robot].target
        known = self._probes.get(robot)
        if known is None or known[0] != target:
            known = self._probes[robot] = (target, self.find_probe(target))
        return known[1]

    def _looking(self, deadline: float | None) -> float | None:
        """The tick's deadline, or sooner while the clock awaits a client's read: the next
        look at its socket."""
        if self.clock.awaits_read is None or deadline is None:
            return deadline
        return min(deadline, time.monotonic() + READ_POLL)

    def _look_for_read(self) -> bool:
        """The clock awaits a client's read of the last state: look (the lock not held, so
        the loop's requests go on meanwhile); True once the clock's deadline came."""
        clock = self.clock
        with self.lock:
            robot = clock.awaits_read
            probe = self._probe(robot)
        began = time.monotonic()
        unread = None if probe is None else probe.unread()
        now = time.monotonic()
        with self.lock:
            if unread is None or now - began > read_probe.LOOK_BUDGET:  # it went, or too slow
                if unread is not None:
                    self._probes[robot] = (self._probes[robot][0], None)
                    too_slow(probe)
                clock.reads_unseen(now)
            elif not unread:
                clock.client_read(now)
            return now >= clock.deadline

    def _read(self, limit: int | None = None) -> bool:
        """Hand every robot's commands that arrived to the cycle (lock held); True if the
        last answer the open state waited for was among them."""
        answered, receive = False, self.cycle.receive
        for robot, endpoint in enumerate(self.endpoints):
            for command in endpoint.read() if limit is None else endpoint.read(limit):
                answered = receive(robot, command) or answered
        return answered

    def _await_answer(self) -> bool:
        """Lockstep: read the sockets for the answer for up to LOCKSTEP_SPIN, without sleeping.

        A client answers within ~50 µs here; a thread that slept meanwhile is woken by the
        kernel and then runs its cycle on cold caches, which made a lockstep cycle ~30 % slower.
        This costs CPU only while a lockstep motion runs, and at most LOCKSTEP_SPIN per cycle (a
        slower answer is waited for asleep, the cycle thread watching the sockets)."""
        spin_until = time.monotonic() + LOCKSTEP_SPIN
        lock = self.lock
        while True:
            with lock:
                answered = self._read(1)
                if answered or (self.faults is not None and self.faults.answered(self.cycle)):
                    return True
            if time.monotonic() > spin_until:
                return False
