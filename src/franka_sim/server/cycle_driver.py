"""The server's side of the cycle: when each cycle goes, and what leaves with it.

The cycle itself (commands in, one step, the state, the rest after the send) is
`robot.cycle.RobotCycle`; this driver runs it as the cycle thread's tick and decides *when*:
at the realtime deadlines, or in lockstep as soon as the client's answer arrives (see
pacing.py). One wake-up per cycle: on a 2-core VM every extra hand-over between threads cost
more CPU than the cycle's own work. Only the tick reads the UDP socket (`poll_commands`: the
endpoint decodes and checks each datagram and hands the commands to `receive`): at each
deadline, and in lockstep also when an answer arrives (the cycle thread watches the socket
while a lockstep cycle waits, see CycleThread.watch). The loop owns the endpoints and serves
TCP. The core is shared between the two threads, so it is only touched with `lock` held: the
tick holds it for the whole cycle, the TCP endpoints for each request.

While the arm is idle the next cycle's command is known at once (the hold), so the tick
releases the next cycle straight after completing the current one, and the next tick only
sends it: idle states leave on their deadline to within this thread's wake-up. During a motion
the command comes from the client, so the cycle is released when its deadline comes (realtime)
or when the answer arrives (lockstep; the tick reads the socket for a moment before it goes to
sleep watching it, see `_await_answer`), and the state leaves as soon as it is packed.

In lockstep, idle time is not wall time: while no client motion runs, the cycles follow the
client's events (a TCP request to the robot or the Hand, a disconnect), so a program of motions,
Hand actions and pauses reproduces to the bit however long the client takes between them:
- a world that is not at rest (the arm settling onto its hold after a motion or a Hand action,
  a recovery or a lost client's stop under way) runs on, cycle after cycle, in one tick that
  keeps the lock, until it is at rest (RobotCycle.at_rest); no request is taken meanwhile, only
  the tick's first state and the last are sent, and the replies of all those cycles go out
  after it. With nothing under way it gets TREMBLE_CYCLES: one that still is not at rest (a
  grasped object's contacts tremble for ever) is taken as it is. A Hand action alone runs on the
  wall clock, a cycle each ms as in realtime: a client may watch the Hand's states and stop it,
  and one that waits for its reply gets it after the same cycles all the same;
- then the world is left as it is (`_frozen`) and the clock holds: the client's next event
  releases the next cycle at once, and only after LOCKSTEP_WINDOW without one does a state go
  out each ms of wall time, the last one again under the next message_id, nothing stepped
  (RobotCycle.repeat: at rest, the very bits a step would give). They keep a client that reads
  states while idle served: libfranka takes only a newer message_id.
So every state a client can see after an event is the same bits in every run; only message_id
counts wall time, and only the wall time a client spends longer than the window between events.

A request's replies wait for the first state published after it (`after_next_state`), and a
reply the cycle itself produced (a Move's end, a recovery) goes out after the state that shows
it: libfranka reads the newest queued state after a reply, which must show what the reply says.

The clock pauses while nobody is connected and the arm has settled (PAUSE_AFTER cycles after
the last client left): nothing can observe it, and an idle fleet of simulators then costs no
CPU. The next client resumes it at once; message_id carries on from where it stopped.
"""

from __future__ import annotations

import asyncio
import collections
import logging
import threading
import time
from typing import Callable

from franka_sim.robot.cycle import Released, Replies, RobotCycle
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.pacing import Pacer

log = logging.getLogger(__name__)

PAUSE_AFTER = 2000  # cycles without a client before the clock pauses (the arm settles first)
# Lockstep, idle: the cycles the world gets to come to rest after a motion or a request when
# nothing is under way (the arm settles onto its hold in ~650); one that still has not (a
# grasped object's contacts tremble for ever at ~1e-6 rad/s) is left as it is. And the most
# cycles one tick runs: work under way that takes longer goes on in the next tick.
TREMBLE_CYCLES = 2000
MAX_SETTLE_CYCLES = 20_000
LOCKSTEP_SPIN = 300e-6  # s a lockstep tick keeps reading the socket for the answer before sleeping

# deliver(replies), on the loop: write a completed cycle's replies to their TCP connections.
Deliver = Callable[[Replies], None]


class CycleDriver:
    def __init__(
        self,
        make_cycle: Callable[[object], RobotCycle],
        thread: CycleThread,
        lock: threading.Lock,
        send_state: Callable[[bytes], None],
        *,
        lockstep: bool = False,
        deliver: Deliver = lambda replies: None,
        has_client: Callable[[], bool] = lambda: True,
        poll_commands: Callable[..., None] = lambda *limit: None,
        command_socket: Callable[[], object] = lambda: None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.make_cycle = make_cycle  # (physics backend) -> RobotCycle, in the cycle thread
        self.cycle: RobotCycle | None = None
        self.thread = thread
        self.lock = lock  # guards the core and the Hand
        self.send_state = send_state  # safe to call from the cycle thread
        self.lockstep = lockstep
        self.deliver = deliver
        self.has_client = has_client
        self.poll_commands = poll_commands  # poll_commands([limit]): datagrams into receive()
        self.command_socket = command_socket  # the socket poll_commands reads (or None)
        self.clock = clock  # the cycle thread's clock (monotonic seconds): deadlines are on it
        self.pacer = Pacer()
        self._inbox: collections.deque = collections.deque()  # poll → tick: decoded commands
        self._awaiting: list[tuple[int, Callable[[], None]]] = []  # loop only: (cycle, deliver)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._running = False
        # Cycle thread only:
        self._prepared: Released | None = None  # an idle cycle released ahead
        self._deadline: float | None = None
        self._unwatched = 0  # cycles since a client was last connected
        # Client events (client_event: loop, lock held) and the count the last released cycle
        # followed: in lockstep, an idle cycle goes at once when they differ.
        self._requests = 0
        self._served = 0
        self._frozen = False  # lockstep, idle: the world is left as it is until a client event
        self._trembling = 0  # lockstep: settling cycles with nothing under way, in a row
        self.paused = False
        # server/faults.NetworkFaults while faults are injected (cycle thread only): in lockstep
        # the client's answer to the state it was last sent releases the next cycle, whatever
        # the network then does with it, and a state that did not reach it is not waited for.
        self.faults = None
        # Lockstep idle cycles that only repeated a state while a client lingered over the
        # window: the one part of message_id that wall time decides. Faults key their fates on
        # message_id less the count when the last motion started (so a motion's cycles get the
        # same fates in every rehearsal, and idle states after it still get fates of their own).
        # With no client their number is fixed (the clock pauses after PAUSE_AFTER).
        self.repeated = 0
        self.key_offset = 0  # `repeated` when the last motion started: faults key on the rest
        self.windows_run_out = 0  # lockstep cycles released without the answer they waited for

    # -- the loop's side -------------------------------------------------------------------------
    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        if self.cycle is None:
            self.cycle = await self.thread.call(self.make_cycle)
        self._running = True
        await self.thread.run_clock(self._tick)

    async def stop(self) -> None:
        self._running = False
        await self.thread.run_clock(None)  # no tick runs after this

    def receive(self, command) -> None:
        """A decoded RobotCommand from the client (cycle thread, from poll_commands): the
        tick hands it to the cycle."""
        self._inbox.append(command)

    def resume(self) -> None:
        """A client arrived: a paused clock starts again at once (a wake-up that finds the
        clock running releases nothing)."""
        self.thread.wake()

    def client_event(self) -> None:
        """A TCP request (robot or Hand) or a client's disconnect, lock held. In lockstep,
        while no client motion runs, it releases the next cycle at once (the idle clock holds
        for the client otherwise)."""
        self._requests += 1
        if self.lockstep:
            self.thread.wake()

    def after_next_state(self, deliver: Callable[[], None]) -> bool:
        """Call `deliver` (a request's replies) once the first state published after now has
        been sent; False while no state is coming (stopped, paused): deliver now. Lock held."""
        if not self._running or self.paused:
            return False
        self._awaiting.append((self.cycle.message_id + 1, deliver))
        return True

    def keep_running(self) -> None:
        """Cycle thread: the world was changed from outside (the control API), so the clock
        runs on, or again, for PAUSE_AFTER cycles, and the change plays out with no client.
        In lockstep it is an event as a client's request is: an idle world frozen for the
        client is stepped again, and a push or a placed body plays out at once."""
        self._unwatched = 0
        if self.lockstep:
            self._requests += 1
            self.thread.wake()
        elif self.paused:
            self.thread.wake()

    def withdraw_prepared(self) -> int | None:
        """Cycle thread, lock held, before a reset: forget the idle cycle released ahead, whose
        state has not left; the next tick releases one anew. The message_id of the last state
        that left (None: nothing was prepared)."""
        prepared, self._prepared = self._prepared, None
        return None if prepared is None else prepared.message_id - 1

    def _sent(self, message_id: int, replies: Replies | None) -> None:
        """The state of `message_id` has left: the replies that waited for it, then its own."""
        awaiting = self._awaiting
        while awaiting and awaiting[0][0] <= message_id:
            awaiting.pop(0)[1]()
        if replies and self._running:
            self.deliver(replies)

    # -- the cycle thread's side -----------------------------------------------------------------
    def _lockstep_now(self) -> bool:
        return self.lockstep and self.cycle.lockstep_applies

    def _answer_awaited(self) -> bool:
        """Lockstep: an answer to the open state releases the next cycle at once. Also for a
        motion's first state, which nothing waits for beyond a period: libfranka never answers
        it, but a client that does has its answer taken at once all the same."""
        cycle = self.cycle
        return self.lockstep and (cycle.lockstep_applies or cycle.first_motion_state)

    def _tick(self, _physics, due: bool) -> float | None:
        try:
            with self.lock:
                deadline = self._tick_locked(due)
            while self._answer_awaited():
                if not self._await_answer():
                    self.thread.watch(self.command_socket())  # wait asleep for the answer
                    break
                with self.lock:
                    deadline = self._tick_locked(False)
            return deadline
        except BaseException:
            self._running = False  # the cycle thread logs it and stops the clock
            raise

    def _await_answer(self) -> bool:
        """Lockstep: read the socket for the answer for up to LOCKSTEP_SPIN, without sleeping.

        A client answers within ~50 µs here; a thread that slept meanwhile is woken by the
        kernel and then runs its cycle on cold caches, which made a lockstep cycle ~30 % slower.
        This costs CPU only while a lockstep motion runs, and at most LOCKSTEP_SPIN per cycle (a
        slower answer is waited for asleep, the worker watching the socket).
        """
        clock = self.clock
        spin_until = clock() + LOCKSTEP_SPIN
        poll, inbox, faults = self.poll_commands, self._inbox, self.faults
        while True:
            poll(1)  # the answer, and not a further read that finds the socket empty
            if inbox or (faults is not None and faults.answered(self.cycle)):
                return True
            if clock() > spin_until:
                return False

    def _tick_locked(self, due: bool) -> float | None:
        cycle = self.cycle
        lockstep = self._answer_awaited()  # (before the answer: it may end the motion)
        moving = cycle.in_motion
        answered = self._take_commands()
        # Only this thread reads the socket: at every deadline, idle ones too (a stray datagram
        # is counted and logged within a cycle); in lockstep also in _await_answer (_tick).
        ready = self._prepared is not None  # an idle cycle released ahead: it goes first
        if due and not ready:
            answered = self._read_socket() or answered
        if self.faults is not None:
            answered = self.faults.answered(cycle)
        requested = (self._requests != self._served and self.lockstep
                     and not cycle.client_driven)
        if not due and not self.paused and not (answered and lockstep) and not requested:
            return self._deadline  # woken, but nothing to release
        self.paused = False
        if due and self.lockstep and cycle.lockstep_applies and not answered:
            self.windows_run_out += 1  # a streaming client's answer did not come in time
        self._served = self._requests
        released, self._prepared = self._prepared, None
        # A motion's cycle (or its last): the client may start its next motion at once, so the
        # cycle after it is decided when it goes, not ahead of it.
        moved = released is None and moving
        if released is None:
            if self._frozen and not requested:  # lockstep's idle time, the client away
                released = cycle.repeat()
                if self.has_client():  # (before a client comes their count is fixed)
                    self.repeated += 1
            else:
                self._frozen = False
                released = cycle.release()
                if cycle.first_motion_state:
                    self.key_offset = self.repeated  # what this motion's cycles are keyed on
        if released.state is not None:
            self.send_state(released.state)
        sent_at = self.clock()  # what the next deadline counts from (pacing.py)
        replies = cycle.complete(released)
        if self.lockstep and not cycle.client_driven:
            if moved or requested:
                self._trembling = 0  # what a motion or a request disturbed gets to settle
            return self._idle_in_lockstep(released, sent_at, replies, requested or moved)
        if replies or self._awaiting:
            try:
                self._loop.call_soon_threadsafe(self._sent, released.message_id, replies)
            except RuntimeError:  # loop closed during shutdown
                pass
        if due and ready:  # no command can answer an idle state: what came
            self._read_socket()  # (strays, junk) is read once the state has left
        self._unwatched = 0 if self.has_client() else self._unwatched + 1
        if self._unwatched >= PAUSE_AFTER and not cycle.in_motion:
            self.paused = True
            self._deadline = None
            return None
        if not cycle.in_motion and not moved:  # idle: the next command is the hold
            self._prepared = cycle.release()
        if self.lockstep and cycle.first_motion_state:
            # Nothing answers a motion's first state (libfranka's handshake reads it): the next
            # goes one period after it, not a lockstep window. A period, not less, so that the
            # handshake has read the first state alone before the second arrives.
            self._deadline = sent_at + self.pacer.period
            return self._deadline
        self._deadline = self.pacer.next_deadline(sent_at, lockstep=self._lockstep_now())
        return self._deadline

    def _idle_in_lockstep(self, released: Released, sent_at: float, replies: Replies,
                          event: bool) -> float | None:
        """Lockstep, no client motion: idle time is not wall time (see the module docstring).

        The world settles in this one tick, cycle after cycle, while the lock keeps every
        request out: so it reaches rest the same number of cycles after the client's event
        however fast this machine is. Of the cycles run here only the last state is sent
        (hundreds of states in a few ms would overflow the client's socket, and a read would
        then find one of them, a different one each run), and every reply of the way waits for
        it. Then the world is left as it is (`_frozen`) until the client's next event."""
        cycle = self.cycle
        settled, more = 0, False
        paused = self._unwatched_pause()
        while not paused and not cycle.at_rest:
            if cycle.hand_busy:
                break  # a Hand action takes its time (a client may watch it and stop it)
            if cycle.busy:
                self._trembling = 0
            elif self._trembling == TREMBLE_CYCLES:
                break  # nothing under way, yet it does not come to rest: left as it is
            else:
                self._trembling += 1
            if settled == MAX_SETTLE_CYCLES:
                more = True  # work this long goes on in the next tick (requests may come between)
                break
            released = cycle.release()
            replies = replies.then(cycle.complete(released))
            settled += 1
            paused = self._unwatched_pause()
        if settled and released.state is not None:
            self.send_state(released.state)
            sent_at = self.clock()
        # Hand states of cycles on the way to rest would reach a client late: only the last.
        self._post(released.message_id, replies)
        if paused:
            return None
        if more:
            self._deadline = sent_at  # at once
            return self._deadline
        if cycle.hand_busy:  # its cycles go on the wall clock, the world stepped and sent
            self._frozen = False
            self._deadline = self.pacer.next_deadline(sent_at, lockstep=False)
            return self._deadline
        if cycle.at_rest:
            self._trembling = 0
        self._frozen = True
        # After the client's event, or the world it disturbed come to rest: hold for its next
        # one (LOCKSTEP_WINDOW). Once that ran out: the world as it is each ms, on the wall clock.
        self._deadline = self.pacer.next_deadline(sent_at, lockstep=bool(event or settled))
        return self._deadline

    def _post(self, message_id: int, replies: Replies) -> None:
        """Hand the loop what waited for the state of `message_id`, now that it has left."""
        if replies or self._awaiting:
            try:
                self._loop.call_soon_threadsafe(self._sent, message_id, replies)
            except RuntimeError:  # loop closed during shutdown
                pass

    def _unwatched_pause(self) -> bool:
        """Count a cycle nobody was connected for; True when the clock pauses now (as
        _tick_locked does inline)."""
        self._unwatched = 0 if self.has_client() else self._unwatched + 1
        if self._unwatched >= PAUSE_AFTER and not self.cycle.in_motion:
            self.paused = True
            self._deadline = None
            return True
        return False

    def _read_socket(self) -> bool:
        """The datagrams on the socket now, to the cycle; True if one answered in time."""
        self.poll_commands()
        return self._take_commands()

    def _take_commands(self) -> bool:
        """Hand the queued commands to the cycle; True if one answered the open cycle in time."""
        answered = False
        inbox, cycle = self._inbox, self.cycle
        while inbox:
            answered = cycle.receive(inbox.popleft()) or answered
        return answered
