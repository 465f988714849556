"""When each cycle of a world goes, and what it is: the clock policy, sans-IO.

The cycle itself is robot/world_cycle.py's; this decides *when* (`realtime` deadlines or
lockstep's answers: pacing.py) and *which*: a step, lockstep's repeat of a world left as it is,
or a hold while a motion awaits its client's first command. It reads no clock and touches no
thread or socket: `tick` is told whether its deadline came and whether the answer it waited for
arrived, hands the states it releases to `send` (which answers when they left: the time the
next deadline counts from), tells `post` after each tick's last state which state that was and
what the cycles left to write (a request's replies wait for it too), and returns the next
deadline. server/cycle_driver.py runs it in the cycle thread.

While the world is idle the next cycle's command is known at once (the hold), so in realtime a
tick releases the next cycle right after completing the current one (`_prepared`), and the next
tick only sends it: idle states leave on their deadline to within the thread's wake-up. During a
motion the cycle is released when its deadline comes (realtime) or when the answer arrives
(lockstep), and its state leaves as soon as it is packed.

In lockstep, idle time is not wall time: while no client motion runs, the cycles follow the
client's events (a TCP request to a robot or a tool, a disconnect: `client_event`; a change
through the control API: `world_changed`), so a program of motions, Hand actions and pauses
reproduces to the bit however long the client takes between them:
- a world that is not at rest (an arm settling onto its hold after a motion or a Hand action, a
  recovery or a lost client's stop under way) runs on, cycle after cycle, in one tick, until it
  is at rest (WorldCycle.at_rest); no request is taken meanwhile (the driver holds the lock),
  only the tick's first state and the last are sent (or, where an injected fault dropped the
  first, each until one reaches the client), and the replies of all those cycles go out
  after it. With nothing under way it gets TREMBLE_CYCLES: one that still is not at rest (a
  grasped object's contacts tremble for ever) is taken as it is. A client's request gives it
  them again, as do a motion's end, a tool's action and a change through the control API; a
  client connecting or leaving does not (`client_event(disturbing=False)`): that costs one
  cycle, not 2000 in which no state goes (a new Gripper's first read timed out on a busy
  machine). A tool's action runs on the wall clock, a cycle each ms as in realtime: a client
  may watch the Hand's states and stop it;
- then the world is left as it is (`_frozen`) and the clock holds: the client's next event
  releases the next cycle at once, and only after LOCKSTEP_WINDOW without one does a state go
  out each ms of wall time, the last one again under the next message_id, nothing stepped
  (`repeat`). They keep a client that reads states while idle served: libfranka takes only a
  newer message_id;
- a motion's first state goes one period after its request's (libfranka never answers it), and
  until the client's first command the world is held (`hold`): however many states the client's
  start-motion handshake read, its first command meets the same world.
So every state a client can see after an event is the same bits in every run. message_id too: a
gap in which the last state went again (the client lingered past the window) is rounded up to
whole IDLE_QUANTUM cycles when the event that ends it comes, the ids in between sent nothing.

The clock pauses while nobody is connected and the world has settled (realtime: PAUSE_AFTER
cycles after the last client left; lockstep: as soon as the world is left as it is): nothing
can observe it, and an idle fleet of simulators then costs no CPU. The next client resumes it
at once (lockstep: its first request); message_id carries on from where it stopped.
"""

from __future__ import annotations

from typing import Callable

from franka_sim.robot.cycle import Cycle
from franka_sim.server.pacing import Pacer

PAUSE_AFTER = 2000  # cycles without a client before the clock pauses (the world settles first)
# Lockstep, idle: the cycles the world gets to come to rest after a motion or a request when
# nothing is under way (an arm settles onto its hold in ~650); one that still has not (a
# grasped object's contacts tremble for ever at ~1e-6 rad/s) is left as it is. And the most
# cycles one tick runs: work under way that takes longer goes on in the next tick.
TREMBLE_CYCLES = 2000
MAX_SETTLE_CYCLES = 20_000
# Lockstep, idle: a gap in which the clock repeated states (the client lingered past the
# window) counts as a whole number of these cycles (1 s), whatever its wall time decided.
IDLE_QUANTUM = 1000
HELD_AT_PERIOD = 2  # held states a motion's start sends START_SPACING apart before it waits
# Lockstep: how far apart a motion's first state and its first held states go (wall time). The
# client's handshake must read each alone, before the next arrives, or it reads one state fewer
# and the run's message_ids shift by one: a period (1 ms) is too little for a client slowed by
# a busy machine. Costs up to 40 ms of wall time per motion start, nothing in robot time.
START_SPACING = 0.02
# Lockstep, a client whose reads the server sees (server/read_probe.py) and whose last start
# showed how many of the start's states it reads before it answers one: each of those goes
# READ_MARGIN after the client read the one before (past the instant its read looks for a
# newer one, however long the machine keeps it from that look), and the state it answers
# waits for its answer (a lockstep window).
READ_MARGIN = 0.002


class ClockWatcher:
    """What the clock tells whoever keeps count of it (the network faults key their fates on
    message_id less the cycles lockstep only repeated while a client lingered)."""

    def repeated(self) -> None:
        """A lockstep idle cycle only repeated a state, a client connected."""

    def motion_started(self, message_id: int) -> None:
        """The state on which a motion's modes flipped was released (its message_id)."""

    def held(self, message_id: int) -> None:
        """A motion's start was held for its client's first command (a repeat whose number the
        client's timing decides), under this message_id."""

    def window_ran_out(self) -> None:
        """A lockstep cycle went without the answer it waited for."""

    def skipped(self, cycles: int) -> None:
        """An idle gap a client lingered in was rounded up by `cycles` ids sent no state."""


class Clock:
    def __init__(self, cycle: Cycle, *, lockstep: bool, send: Callable[[tuple], float],
                 post: Callable[[int, object], None], has_client: Callable[[], bool],
                 pacer: Pacer | None = None,
                 reads_seen: Callable[[int], bool] = lambda robot: False,
                 unseen: Callable[[int], bool] = lambda since: False) -> None:
        self.cycle = cycle
        self.lockstep = lockstep
        self.send = send  # send(states) -> the time they left
        self.post = post  # post(message_id, replies): once that state left, write them
        self.has_client = has_client
        self.reads_seen = reads_seen  # reads_seen(robot): its client's reads can be seen
        # unseen(since): a connected client was sent no state of cycle `since` or later (an
        # injected fault dropped them)
        self.unseen = unseen
        self.pacer = pacer or Pacer()
        self.watcher = ClockWatcher()
        self.paused = False
        self.deadline: float | None = None
        # Lockstep, a motion's start: the robot whose client's read of the last state the next
        # deadline waits for (`client_read`), else None.
        self.awaits_read: int | None = None
        self.prepared = None  # an idle cycle released ahead (realtime)
        self._unwatched = 0  # cycles since a client was last connected (< 0: a push still acts)
        # Client events and the count the last released cycle followed: in lockstep, an idle
        # cycle goes at once when they differ.
        self._events = 0
        self._served = 0
        self._frozen = False  # lockstep, idle: the world is left as it is until a client event
        self._gap = 0  # lockstep: states repeated since the world froze (the idle gap)
        self._held = 0  # lockstep: held states since the last step (a motion's start)
        self._gap_watched = False  # a client was connected through it
        self._trembling = 0  # lockstep: settling cycles with nothing under way, in a row
        self._disturbed = False  # lockstep: a request or a change came since the last tick
        # Lockstep: the server itself keeps its client waiting (the control API's HTTP server
        # being loaded on its first connection): no cycle goes without its answer meanwhile.
        self.server_busy = 0

    # -- events ------------------------------------------------------------------------------------
    def client_event(self, disturbing: bool = True) -> None:
        """A TCP request (to a robot or a tool) or a client's disconnect; not `disturbing`: a
        Connect alone, or a disconnect (whatever either sets going is a motion or a tool's
        action, which the world's settling sees for itself)."""
        self._events += 1
        self._disturbed = self._disturbed or disturbing

    def world_changed(self, cycles: int = 0) -> None:
        """The world was changed from outside (the control API), a change that acts for
        `cycles` (a push): the clock runs on, or again, for those and PAUSE_AFTER more, so the
        change plays out with no client; in lockstep it is an event as a client's request is."""
        self._unwatched = min(0, self._unwatched, -cycles)
        if self.lockstep:
            self._events += 1
            self._disturbed = True

    def withdraw_prepared(self) -> int | None:
        """Before a reset: forget the idle cycle released ahead, whose state has not left; the
        next tick releases one anew. The message_id of the last state that left (None: nothing
        was prepared)."""
        prepared, self.prepared = self.prepared, None
        if prepared is None:
            return None
        self.cycle.rewind(prepared.message_id - 1)
        return prepared.message_id - 1

    def client_read(self, now: float) -> None:
        """The client `awaits_read` named has read the last state (at `now`): the next goes
        READ_MARGIN after, unless it was due sooner."""
        self.awaits_read = None
        if self.deadline is not None:
            self.deadline = min(self.deadline, now + READ_MARGIN)

    def reads_unseen(self, now: float) -> None:
        """The reads `awaits_read` waited for can no longer be seen (the client's socket went,
        or looking grew too slow): the next state goes START_SPACING after `now` at the
        latest, as for a client never seen."""
        self.awaits_read = None
        if self.deadline is not None:
            self.deadline = min(self.deadline, now + START_SPACING)

    # -- questions the driver asks -----------------------------------------------------------------
    @property
    def answer_awaited(self) -> bool:
        """Lockstep: an answer to the open state releases the next cycle at once. Also for a
        motion's first state, which nothing waits for beyond a period: libfranka never answers
        it, but a client that does has its answer taken at once all the same."""
        cycle = self.cycle
        return self.lockstep and (cycle.lockstep_applies or cycle.first_motion_state
                                  or cycle.holds_start)

    # -- the tick ----------------------------------------------------------------------------------
    def tick(self, due: bool, answered: bool, awaited: bool) -> float | None:
        """Release what is due now; the next deadline (None: only when woken). `due`: the
        deadline came (False: woken early); `answered`: every answer the open state waited for
        came; `awaited`: `answer_awaited` as it was before those answers were taken (an answer
        may end the motion)."""
        cycle = self.cycle
        lockstep = self.lockstep
        moving = cycle.in_motion
        requested = self._events != self._served and lockstep and not cycle.client_driven
        # (Woken before the first tick, by a client ahead of the thread's first deadline, there
        # is no deadline to go back to: that tick runs now, or the clock would never start.)
        started = self.deadline is not None
        if not due and started and not self.paused and not (answered and awaited) \
                and not requested:
            return self.deadline  # woken, but nothing to release
        self.awaits_read = None  # (whatever this tick sends is read anew)
        if self.paused and lockstep and not requested:
            return None  # a connection alone is no event: its first request resumes lockstep
        self.paused = False
        if due and lockstep and cycle.lockstep_applies and not answered:
            if self.server_busy:  # the client waits for us, not we for it: wait on
                self.deadline = self.pacer.extend(self.deadline)
                return self.deadline
            self.watcher.window_ran_out()
        self._served = self._events
        released, self.prepared = self.prepared, None
        # A motion's cycle (or its last): the client may start its next motion at once, so the
        # cycle after it is decided when it goes, not ahead of it.
        moved = released is None and moving
        if released is None:
            released = self._release(requested)
        sent_at = self.send(released.states)
        replies = cycle.complete(released)
        if lockstep and not cycle.client_driven:
            # What a motion, a request or a change disturbed gets to settle (not a client's
            # coming or going: see the module docstring).
            if moved or (requested and self._disturbed):
                self._trembling = 0
            self._disturbed = False
            return self._idle_in_lockstep(released, sent_at, replies, requested or moved)
        self.post(released.message_id, replies)
        if self._count_unwatched():
            return self._pause()
        if not cycle.in_motion and not moved:  # idle: the next command is the hold
            self.prepared = cycle.release()
        if lockstep and (cycle.first_motion_state or cycle.holds_start):
            self.deadline = self._start_deadline(sent_at)
        else:
            self.deadline = self.pacer.next_deadline(
                sent_at, lockstep=lockstep and cycle.lockstep_applies)
        return self.deadline

    def _start_deadline(self, sent_at: float) -> float:
        """Lockstep, a motion's start: when the state after the one sent at `sent_at` goes.

        Nothing answers a motion's first state (libfranka's handshake reads it), and the world
        is held for the client's first command: libfranka's loop answers the state after the
        first, a pylibfranka program that reads once before its loop the one after that. The
        first HELD_AT_PERIOD after the first state go START_SPACING apart, long enough that
        the client has read each alone before the next arrives; then the first command
        releases the next cycle when it comes, and another held state goes only after a
        window: a client slow over its first command reads no more of them.

        A client whose reads can be seen, and whose last start said how many of these states
        it reads before it answers one, is not kept waiting: each goes READ_MARGIN after it
        read the one before (`awaits_read`; at the latest after a window), and the one it
        answers waits for its answer. Either way it reads the same states."""
        held = self._held  # states held since the first (0: this is the first)
        if held >= HELD_AT_PERIOD:
            return self.pacer.next_deadline(sent_at, lockstep=True)
        starting = self.cycle.starting
        if starting is None or starting[1] is None or not self.reads_seen(starting[0]):
            return sent_at + START_SPACING
        if held < starting[1]:
            self.awaits_read = starting[0]
        return self.pacer.next_deadline(sent_at, lockstep=True)

    def _release(self, requested: bool):
        """The cycle that goes now: lockstep's repeat or hold where they apply, else a step."""
        cycle = self.cycle
        if self.lockstep:
            if self._frozen and not requested:  # lockstep's idle time, the client away
                self._gap_watched = self.has_client()
                if self._gap_watched:  # (before a client comes their count is fixed)
                    self.watcher.repeated()
                self._gap += 1
                return cycle.repeat()
            if self._gap:
                self._round_up_gap()
            if cycle.holds_start:
                held = cycle.hold()
                if held is not None:
                    self._held += 1
                    self.watcher.held(held.message_id)
                    return held
        self._frozen = False
        released = cycle.release()
        self._held = 0
        if cycle.first_motion_state:
            self.watcher.motion_started(released.message_id)
        return released

    def _round_up_gap(self) -> None:
        """An event ends an idle gap: the clock moves on to the next whole IDLE_QUANTUM of
        cycles since the gap began, no state sent, so the message_id (the client's `time`)
        after it is the same however long the client lingered (up to the quantum)."""
        gap, self._gap = self._gap, 0
        cycles = -gap % IDLE_QUANTUM
        if cycles:
            self.cycle.skip(cycles)
            if self._gap_watched:
                self.watcher.skipped(cycles)

    def _idle_in_lockstep(self, released, sent_at: float, replies, event: bool) -> float | None:
        """Lockstep, no client motion: idle time is not wall time (see the module docstring).

        The world settles in this one tick, cycle after cycle, while the driver's lock keeps
        every request out: so it reaches rest the same number of cycles after the client's
        event however fast this machine is. Of the cycles run here only the last state is sent
        (hundreds of states in a few ms would overflow the client's socket, and a read would
        then find one of them, a different one each run), and every reply of the way waits for
        it. Then the world is left as it is (`_frozen`) until the client's next event.

        Unless an injected fault dropped the tick's first state (a burst over a motion's
        reflex): then the cycles' states go until one reaches each client, as the robot's next
        would, so its client sees the motion end a few cycles on, not at the last (libfranka
        counts the cycles between the last two states it read as lost)."""
        cycle = self.cycle
        settled, more = 0, False
        first, last_sent = released.message_id, True
        paused = self._count_unwatched()
        while not paused and not cycle.at_rest:
            if cycle.tool_busy:  # a tool's action takes its time (a client may watch it and
                self._trembling = 0  # stop it); what it moved then gets to settle
                break
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
            last_sent = self.unseen(first)
            if last_sent:
                sent_at = self.send(released.states)
            replies = replies.then(cycle.complete(released))
            settled += 1
            paused = self._count_unwatched()
        if not last_sent:
            sent_at = self.send(released.states)
        # Tool states of cycles on the way to rest would reach a client late: only the last.
        self.post(released.message_id, replies)
        if paused:
            return self._pause()
        if more:
            self.deadline = sent_at  # at once
            return self.deadline
        if cycle.tool_busy:  # its cycles go on the wall clock, the world stepped and sent
            self._frozen = False
            self.deadline = self.pacer.next_deadline(sent_at, lockstep=False)
            return self.deadline
        if cycle.at_rest:
            self._trembling = 0
        self._frozen = True
        if not self.has_client():
            return self._pause()  # nobody could read a state: none goes until an event
        # After the client's event, or the world it disturbed come to rest: hold for its next
        # one (LOCKSTEP_WINDOW). Once that ran out: the world as it is each ms, on the wall clock.
        self.deadline = self.pacer.next_deadline(sent_at, lockstep=bool(event or settled))
        return self.deadline

    def _count_unwatched(self) -> bool:
        """Count a cycle nobody was connected for; True once PAUSE_AFTER of them passed."""
        self._unwatched = 0 if self.has_client() else self._unwatched + 1
        return self._unwatched >= PAUSE_AFTER and not self.cycle.in_motion

    def _pause(self) -> None:
        self.paused = True
        self.deadline = None
        self.pacer.restart()
        return None
