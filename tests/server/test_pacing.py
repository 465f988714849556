"""The clock policy: absolute 1 ms deadlines, a floor on the spacing of two states, lockstep.

Pure arithmetic on given times (the Pacer), the clock policy on fake time, and the cycle
driver on a fake thread: no test here depends on how fast this machine runs.
"""

from __future__ import annotations

import asyncio
import threading

import pytest

from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.protocol.enums import MoveStatus
from franka_sim.robot.world_cycle import WorldCycle
from franka_sim.server.clock import PAUSE_AFTER, Clock, ClockWatcher
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.pacing import LOCKSTEP_WINDOW, PERIOD, Pacer

from support.harness import Harness

MS = 1e-3


def test_deadlines_are_absolute_so_the_rate_does_not_drift():
    pacer = Pacer()
    sent = 10.0
    deadlines = []
    for k in range(1, 1001):
        deadline = pacer.next_deadline(sent, lockstep=False)
        deadlines.append(deadline)
        sent = deadline + 0.07 * MS  # each state leaves 70 µs after its deadline
    assert deadlines[-1] == pytest.approx(10.0 + 1000 * PERIOD, abs=1e-9)


def test_after_an_overrun_states_catch_up_at_the_minimum_spacing():
    pacer = Pacer()
    pacer.next_deadline(0.0, lockstep=False)  # anchored at 0: deadlines at k ms
    late = 3.2 * MS  # cycle 1 (due at 1 ms) left at 3.2 ms
    deadline = pacer.next_deadline(late, lockstep=False)
    assert deadline == pytest.approx(late + pacer.min_spacing)
    spacing = []
    sent = late
    for _ in range(6):
        deadline = pacer.next_deadline(deadline, lockstep=False)
        spacing.append(deadline - sent)
        sent = deadline
    assert min(spacing) >= pacer.min_spacing - 1e-12
    assert spacing[-2:] == pytest.approx([PERIOD, PERIOD])  # caught up: back on the
    assert deadline == pytest.approx(8 * MS)  # absolute schedule, 1 ms apart


def test_a_stall_too_long_to_catch_up_reanchors():
    pacer = Pacer()
    pacer.next_deadline(0.0, lockstep=False)
    deadline = pacer.next_deadline(1.0, lockstep=False)  # a frozen host: 1 s later
    assert deadline == pytest.approx(1.0 + PERIOD)
    assert pacer.stalls == 1 and pacer.behind == pytest.approx(1.0 - 2 * PERIOD)  # (cycle 2)


def test_a_clock_that_paused_anchors_anew_without_a_stall():
    pacer = Pacer()
    pacer.next_deadline(0.0, lockstep=False)
    pacer.restart()  # (nobody connected: the clock paused)
    assert pacer.next_deadline(5.0, lockstep=False) == pytest.approx(5.0 + PERIOD)
    assert pacer.stalls == 0


def test_lockstep_waits_a_window_from_when_the_state_left():
    pacer = Pacer()
    assert pacer.next_deadline(5.0, lockstep=True) == 5.0 + LOCKSTEP_WINDOW


class _FakeTime:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def clock_for(harness: Harness, send, **kwargs) -> Clock:
    """The clock policy running the harness's arm as a world of one."""
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    return Clock(world, send=send, post=lambda message_id, replies: None,
                 has_client=lambda: True, **kwargs)


@pytest.mark.parametrize("lockstep", [False, True])
def test_a_wake_before_the_first_tick_starts_the_clock(lockstep):
    """A client that connects before the cycle thread ran its first (due) tick wakes it first:
    that tick must start the clock, not return the deadline it does not have yet (which left
    the clock stopped and the client's Connect reply, which waits for a state, unsent)."""
    left: list[float] = []

    def send(states) -> float:
        left.append(len(left) * PERIOD)
        return left[-1]

    clock = clock_for(Harness(), send, lockstep=lockstep)
    deadline = clock.tick(False, False, False)
    assert left and deadline is not None
    assert clock.tick(False, False, False) == deadline  # then a wake is only a wake


def test_a_paused_clock_starts_again_when_a_client_wakes_it():
    """Nobody connected for PAUSE_AFTER cycles: the clock pauses (no deadline); a client's
    arrival wakes it, and that tick releases a state again."""
    left: list[float] = []
    client = [False]

    def send(states) -> float:
        left.append(len(left) * PERIOD)
        return left[-1]

    harness = Harness()
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    clock = Clock(world, send=send, post=lambda message_id, replies: None,
                  has_client=lambda: client[0], lockstep=False)
    deadline = clock.tick(True, False, False)
    for _ in range(PAUSE_AFTER + 1):
        if deadline is None:
            break
        deadline = clock.tick(True, False, False)
    assert deadline is None and clock.paused
    sent = len(left)
    client[0] = True
    assert clock.tick(False, False, False) is not None  # the wake of the client's arrival
    assert len(left) == sent + 1 and not clock.paused


def test_a_push_with_no_client_runs_its_whole_duration_before_the_clock_pauses():
    """A change that acts for a while (a push of 2500 cycles, given through the control API
    with nobody connected) keeps the clock going for all of it and PAUSE_AFTER more: a
    pause halfway would leave the push on for the next client to feel."""
    ticks = []
    harness = Harness()
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    clock = Clock(world, send=lambda states: len(ticks) * PERIOD,
                  post=lambda message_id, replies: None, has_client=lambda: False,
                  lockstep=False)
    clock.world_changed(2500)
    deadline = clock.tick(True, False, False)
    while deadline is not None and len(ticks) < 10_000:
        ticks.append(deadline)
        deadline = clock.tick(True, False, False)
    assert clock.paused and len(ticks) == 2500 + PAUSE_AFTER - 1


def test_the_spacing_counts_from_when_the_state_left_not_when_its_cycle_began():
    """A thread held up inside a send (preempted, a busy host) sends that state late; the next
    state must still leave at least min_spacing after it, not min_spacing after the late
    cycle began."""
    time = _FakeTime()
    left: list[float] = []
    hold_up = [0.0]

    def send(states) -> float:
        time.now += hold_up[0]
        left.append(time.now)
        return time.now

    harness = Harness()
    clock = clock_for(harness, send, lockstep=False)
    deadline = clock.tick(True, False, False)  # anchored at 0
    assert deadline == pytest.approx(PERIOD)
    time.now = 3.0 * MS  # the next tick woke 2 ms late
    hold_up[0] = 0.4 * MS  # and the send then took 0.4 ms
    deadline = clock.tick(True, False, False)
    assert deadline >= left[-1] + clock.pacer.min_spacing
    time.now, hold_up[0] = deadline, 0.0
    clock.tick(True, False, False)
    assert left[-1] - left[-2] >= clock.pacer.min_spacing


def test_a_motion_state_leaves_before_the_rest_of_its_step_is_done():
    """The part of a step that no reading needs (physics: finish_step) runs once the state has
    left, so a lockstep client never waits for it; and it has run before the tick returns."""
    harness = Harness()
    unfinished_at_send: list[bool] = []

    def send(states) -> float:
        unfinished_at_send.append(harness.backend._unfinished)
        harness.state = decode_state(states[0])
        return 0.0

    clock = clock_for(harness, send, lockstep=False)
    assert harness.move(2, 4) == MoveStatus.kMotionStarted  # torque control
    clock.tick(True, False, False)  # the state that shows the motion running
    unfinished_at_send.clear()
    for _ in range(3):  # the motion's cycles, each answered as a client does (a torque
        # command reused unanswered is the last step's inputs again: that step is finished at
        # once, to see whether the world came to rest, docs/architecture.md)
        harness.send(tau_J_d=[0.5, 0, 0, 0, 0, 0, 0])
        clock.tick(True, False, False)
        assert not harness.backend._unfinished
    assert unfinished_at_send == [True, True, True]


class _Thread:
    """The cycle thread as the driver uses it: jobs run at once, the tick is the test's."""

    def __init__(self) -> None:
        self.watched: list = []
        self.jobs_waiting = False  # a control-API job queued behind the tick

    async def call(self, fn, *args):
        return fn(None, *args)

    async def run_clock(self, tick) -> None:
        self.tick = tick

    def wake(self) -> None:
        pass

    def watch(self, sockets) -> None:
        self.watched.append(sockets)


class _Endpoint:
    """A robot's UDP endpoint: datagrams the test puts on it, states it was sent."""

    def __init__(self) -> None:
        self.sock = object()  # what the thread is asked to watch (it only passes it on)
        self.on_socket: list[bytes] = []
        self.sent: list[int] = []

    def read(self, limit: int = 64) -> list:
        taken, self.on_socket = self.on_socket[:limit], self.on_socket[limit:]
        return [decode_command(data) for data in taken]

    def send_state(self, data: bytes) -> None:
        self.sent.append(int(decode_state(data)["message_id"]))


def test_a_lockstep_cycle_waits_for_its_answer_watching_the_command_sockets():
    """In lockstep only the cycle thread reads the answers. When its short spin finds none,
    the tick has the thread watch the robots' sockets; the wake that follows (not due) reads
    the answer and releases the next cycle at once. No answer, no cycle."""
    harness = Harness()
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    thread, endpoint = _Thread(), _Endpoint()
    driver = CycleDriver(lambda physics: world, thread, threading.Lock(), lockstep=True,
                         deliver=lambda replies, clients: None, clients=lambda: None,
                         has_client=lambda: True, watcher=ClockWatcher())
    asyncio.run(driver.start([endpoint]))
    assert harness.move(2, 4) == MoveStatus.kMotionStarted  # torque control
    deadline = thread.tick(None, True)  # the motion's first state; no answer yet
    assert thread.watched == [(endpoint.sock,)]
    assert deadline == pytest.approx(driver.clock.deadline)
    sent = endpoint.sent
    first = len(sent)

    thread.tick(None, False)  # woken with nothing on the socket: nothing goes
    assert len(sent) == first and thread.watched == [(endpoint.sock,)] * 2

    endpoint.on_socket.append(encode_command(message_id=sent[-1], tau_J_d=[0.0] * 7))
    thread.tick(None, False)  # the datagram woke it: the next cycle goes at once
    assert sent[first:] == [sent[first - 1] + 1]
    assert harness.core.success_rate > 0.0
    assert thread.watched == [(endpoint.sock,)] * 3  # and it waits for the next answer again


class _AnsweringEndpoint(_Endpoint):
    """A client that answers each state at once (a C++ loop does, within the tick's spin),
    `answers` times."""

    def __init__(self, answers: int, answered=lambda: None) -> None:
        super().__init__()
        self.answers, self.answered = answers, answered

    def read(self, limit: int = 64) -> list:
        if self.answers and self.sent and not self.on_socket:
            self.answers -= 1
            self.on_socket.append(encode_command(message_id=self.sent[-1], tau_J_d=[0.0] * 7))
            self.answered()
        return super().read(limit)


def _answered_cycles(job_comes: bool) -> int:
    """How many cycles one lockstep tick runs for a client that answers at once (6 times);
    `job_comes`: a job is queued for the cycle thread as the first answer arrives."""
    harness = Harness()
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    thread = _Thread()
    endpoint = _AnsweringEndpoint(0, lambda: setattr(thread, "jobs_waiting", job_comes))
    driver = CycleDriver(lambda physics: world, thread, threading.Lock(), lockstep=True,
                         deliver=lambda replies, clients: None, clients=lambda: None,
                         has_client=lambda: True, watcher=ClockWatcher())
    asyncio.run(driver.start([endpoint]))
    assert harness.move(2, 4) == MoveStatus.kMotionStarted  # torque control
    thread.tick(None, True)  # the motion's first state; the client starts answering now
    endpoint.answers = 6
    before = len(endpoint.sent)
    thread.tick(None, False)
    assert thread.watched[-1] == (endpoint.sock,)  # either way it then waits for an answer
    return len(endpoint.sent) - before


def test_a_queued_job_ends_a_lockstep_tick_a_quick_client_would_keep():
    """A tick runs cycle after cycle while the answers come within its spin; a job queued
    for the cycle thread (a control-API call) ends it after its cycle, so the job runs
    before the next one instead of after the motion."""
    assert _answered_cycles(job_comes=False) == 6
    assert _answered_cycles(job_comes=True) == 1
