"""The clock policy: absolute 1 ms deadlines, a floor on the spacing of two states, lockstep.

Pure arithmetic on given times (the Pacer), and the cycle driver on a fake clock: no test here
depends on how fast this machine runs.
"""

from __future__ import annotations

import threading

import pytest

from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.protocol.enums import MoveStatus
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


def test_lockstep_waits_a_window_from_when_the_state_left():
    pacer = Pacer()
    assert pacer.next_deadline(5.0, lockstep=True) == 5.0 + LOCKSTEP_WINDOW


class _FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class _Worker:
    def __init__(self) -> None:
        self.watched: list = []

    def wake(self) -> None:
        pass

    def watch(self, sock) -> None:
        self.watched.append(sock)


def driver_for(harness: Harness, *args, **kwargs) -> CycleDriver:
    """A driver ticking the harness's own cycle (its start() would build one in the thread)."""
    driver = CycleDriver(lambda physics: harness.robot_cycle, *args, **kwargs)
    driver.cycle = harness.robot_cycle
    return driver


def test_the_spacing_counts_from_when_the_state_left_not_when_its_cycle_began():
    """A thread held up inside a send (preempted, a busy host) sends that state late; the next
    state must still leave at least min_spacing after it, not min_spacing after the late
    cycle began."""
    clock = _FakeClock()
    left: list[float] = []
    hold_up = [0.0]

    def send_state(data: bytes) -> None:
        clock.now += hold_up[0]
        left.append(clock.now)

    harness = Harness()
    driver = driver_for(harness, _Worker(), threading.Lock(), send_state, clock=clock)
    deadline = driver._tick(harness.backend, True)  # anchored at 0
    assert deadline == pytest.approx(PERIOD)
    clock.now = 3.0 * MS  # the next tick woke 2 ms late
    hold_up[0] = 0.4 * MS  # and the send then took 0.4 ms
    deadline = driver._tick(harness.backend, True)
    assert deadline >= left[-1] + driver.pacer.min_spacing
    clock.now, hold_up[0] = deadline, 0.0
    driver._tick(harness.backend, True)
    assert left[-1] - left[-2] >= driver.pacer.min_spacing


def test_a_motion_state_leaves_before_the_rest_of_its_step_is_done():
    """The part of a step that no reading needs (physics: finish_step) runs once the state has
    left, so a lockstep client never waits for it; and it has run before the tick returns."""
    harness = Harness()
    unfinished_at_send: list[bool] = []

    def send_state(data: bytes) -> None:
        unfinished_at_send.append(harness.backend._unfinished)

    driver = driver_for(harness, _Worker(), threading.Lock(), send_state,
                         clock=_FakeClock())
    assert harness.move(2, 4) == MoveStatus.kMotionStarted  # torque control
    driver._tick(harness.backend, True)  # the state that shows the motion running
    unfinished_at_send.clear()
    for _ in range(3):  # the motion's cycles (unanswered: the last torques are reused)
        driver._tick(harness.backend, True)
        assert not harness.backend._unfinished
    assert unfinished_at_send == [True, True, True]


def test_a_lockstep_cycle_waits_for_its_answer_watching_the_command_socket():
    """In lockstep only the physics thread reads the answers. When its short spin finds none,
    the tick has the worker watch the command socket; the wake that follows (not due) reads the
    answer and releases the next cycle at once. No answer, no cycle."""
    harness = Harness()
    sent: list[int] = []
    on_socket: list[bytes] = []
    command_socket = object()  # what the worker is asked to watch (it only passes it on)
    worker = _Worker()

    def poll_commands(limit: int = 64) -> None:
        for _ in range(min(limit, len(on_socket))):
            driver.receive(decode_command(on_socket.pop(0)))

    driver = driver_for(harness, worker, threading.Lock(),
                         lambda data: sent.append(int(decode_state(data)["message_id"])),
                         lockstep=True, poll_commands=poll_commands,
                         command_socket=lambda: command_socket)
    assert harness.move(2, 4) == MoveStatus.kMotionStarted  # torque control
    deadline = driver._tick(harness.backend, True)  # the motion's first state; no answer yet
    assert worker.watched == [command_socket]
    assert deadline == pytest.approx(driver._deadline)
    first = len(sent)

    driver._tick(harness.backend, False)  # woken with nothing on the socket: nothing goes
    assert len(sent) == first and worker.watched == [command_socket] * 2

    on_socket.append(encode_command(message_id=sent[-1], tau_J_d=[0.0] * 7))
    driver._tick(harness.backend, False)  # the datagram woke it: the next cycle goes at once
    assert sent[first:] == [sent[first - 1] + 1]
    assert harness.core.success_rate > 0.0
    assert worker.watched == [command_socket] * 3  # and it waits for the next answer again
