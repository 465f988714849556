"""The command cycle, specified on the sans-IO robot core (no sockets, no clock).

Each published state opens a cycle; the command echoing its message_id closes it on time if
it arrives before the next cycle is released. Misses are extrapolated, counted, reported as
control_command_success_rate, and — with enforcement — abort after 20 in a row
(tests/robot/test_silent_client.py).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from franka_sim.protocol.enums import (
    AutomaticErrorRecoveryStatus as AER,
    Command,
    MoveStatus,
    RobotMode,
)
from support.harness import Harness, running_velocity_motion


def test_modes_flip_on_the_first_state_after_motion_started():
    h = Harness()
    assert h.move(0, 1) == MoveStatus.kMotionStarted
    assert h.state["robot_mode"] == RobotMode.kIdle  # not before the next cycle
    s = h.cycle()
    assert (s["robot_mode"], s["motion_generator_mode"], s["controller_mode"]) == (2, 2, 0)


def test_success_rate_counts_answered_cycles_over_the_last_100():
    h = running_velocity_motion()
    for _ in range(100):  # all answered: outside the window by the end
        assert h.send(dq_c=np.zeros(7))
        h.cycle()
    for i in range(100):
        if i % 4 != 3:  # every fourth cycle goes unanswered
            assert h.send(dq_c=np.zeros(7))
        h.cycle()
    assert h.state["control_command_success_rate"] == pytest.approx(0.75)  # not 175/200


def test_a_loss_burst_leaves_the_rate_once_100_answered_cycles_followed():
    h = running_velocity_motion()
    h.send(dq_c=np.zeros(7))
    h.cycle(51)  # 50 lost in a row
    assert h.state["control_command_success_rate"] < 0.6
    for _ in range(100):
        h.send(dq_c=np.zeros(7))
        h.cycle()
    assert h.state["control_command_success_rate"] == 1.0


def test_the_rate_starts_with_the_first_command():
    """libfranka never answers the state on which the modes flip: that is not a loss."""
    h = running_velocity_motion()
    h.cycle()  # the flip state, unanswered as libfranka leaves it
    for _ in range(10):
        h.send(dq_c=np.zeros(7))
        h.cycle()
    assert h.state["control_command_success_rate"] == 1.0


def test_idle_success_rate_is_zero():
    h = running_velocity_motion()
    for _ in range(10):
        h.send(dq_c=np.zeros(7))
        h.cycle()
    assert h.state["control_command_success_rate"] == 1.0
    h.send(dq_c=np.zeros(7), motion_generation_finished=True)
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kIdle
    assert h.state["control_command_success_rate"] == 0.0  # idle again: 0, not the last rate
    h.cycle(5)
    assert h.state["control_command_success_rate"] == 0.0


def test_a_late_command_is_dropped_and_counts_as_lost():
    """As the robot drops it: its cycle was extrapolated already, and applied a cycle late it
    would step the stream back by one cycle's travel."""
    h = running_velocity_motion()
    stale = int(h.state["message_id"])
    h.cycle()  # the window of `stale` closed unanswered
    assert not h.send(message_id=stale, dq_c=np.full(7, 0.1))
    h.cycle()
    assert not np.asarray(h.state["dq_d"]).any()  # still the extrapolated rest
    assert (h.core.window.lost_total, h.core.window.late_total) == (2, 1)


def test_an_id_never_published_answers_nothing():
    h = running_velocity_motion()
    future = int(h.state["message_id"]) + 5
    assert not h.send(message_id=future, dq_c=np.zeros(7))
    h.cycle()
    assert h.core.window.invented_total == 1 and h.core.window.lost_total == 1


def test_missed_cycles_extrapolate_at_constant_acceleration():
    h = running_velocity_motion()
    for dq in (0.0, 0.001, 0.002):
        h.send(dq_c=np.full(7, dq))
        h.cycle()
    # acceleration 1 rad/s² frozen when the gap begins: dq_d goes on rising 1e-3 per cycle
    for k in range(1, 21):
        h.cycle()
        np.testing.assert_allclose(h.state["dq_d"], 0.002 + k * 0.001, atol=1e-6)
        np.testing.assert_allclose(h.state["ddq_d"], 1.0, atol=1e-3)
    # after 20 the robot would abort; unenforced, it brakes the arm from where it measures it,
    # no joint slowing faster than 10 rad/s², all reaching rest together; then it holds there
    speed = np.abs(np.asarray(h.state["dq"], dtype=float))
    for _ in range(3):
        h.cycle()
        dq_d = np.abs(np.asarray(h.state["dq_d"], dtype=float))
        assert np.all(dq_d < speed) or not dq_d.any()
        assert np.abs(h.state["ddq_d"]).max() <= 10.0 + 1e-3
        speed = dq_d
    assert not np.asarray(h.state["dq_d"]).any()
    q_d = np.array(h.state["q_d"])
    for _ in range(5):
        h.cycle()
        assert not np.asarray(h.state["dq_d"]).any() and not np.asarray(h.state["ddq_d"]).any()
        assert np.array_equal(h.state["q_d"], q_d)


def test_a_limit_check_that_only_logs_runs_once_the_state_has_left(caplog):
    """Without enforcement a violation changes nothing a client sees, so its check waits until
    the state is out (a lockstep client is not kept waiting for it): still logged, and the
    command still applied."""
    h = running_velocity_motion()
    with caplog.at_level(logging.WARNING, logger="franka_sim.robot.checks"):
        assert h.send(dq_c=np.full(7, 0.5))  # a jump from rest: a discontinuity
        assert not caplog.records  # not judged yet
        h.cycle()
    assert [r.getMessage() for r in caplog.records if "not enforced" in r.getMessage()]
    assert h.state["dq_d"] == pytest.approx(np.full(7, 0.5))
    assert h.state["robot_mode"] == RobotMode.kMove


def test_non_finite_command_is_dropped_not_applied():
    h = running_velocity_motion()
    bad = np.zeros(7)
    bad[2] = np.nan
    assert not h.send(dq_c=bad)
    h.cycle()
    assert np.all(np.isfinite(h.state["dq_d"])) and np.all(np.isfinite(h.state["q"]))


def test_finishing_answers_the_move_and_holds_the_final_pose():
    h = Harness()
    h.move(0, 0)
    h.cycle()
    q = np.array(h.state["q_d"], dtype=float)
    target = q.copy()
    for _ in range(200):
        target[6] += 1e-4
        h.send(q_c=target)
        h.cycle()
    h.send(q_c=target, motion_generation_finished=True)
    h.cycle()
    assert (Command.Move, 5, MoveStatus.kSuccess) in h.statuses()
    assert h.state["robot_mode"] == RobotMode.kIdle and h.state["motion_generator_mode"] == 0
    h.cycle(500)
    assert abs(h.state["q"][6] - target[6]) < 1e-5


def test_finishing_while_still_moving_is_a_reflex_abort():
    h = running_velocity_motion()
    h.send(dq_c=np.full(7, 0.3), motion_generation_finished=True)
    h.cycle()
    assert (Command.Move, 5, MoveStatus.kReflexAborted) in h.statuses()


@pytest.mark.parametrize(
    "controller, generator",
    [(0, 4), (1, 4), (7, 0), (0, 9)],
)
def test_invalid_mode_pairs_are_rejected_as_invalid_arguments(controller, generator):
    assert Harness().move(controller, generator) == MoveStatus.kInvalidArgumentRejected


def test_an_async_target_answering_a_state_long_gone_is_followed():
    """libfranka's async handler sends each target once, echoing the last state its program
    read: a program that sleeps between reads and targets answers a state long gone. The
    robot's own generator takes the target all the same (its last one sent, in one cycle)."""
    h = Harness()
    assert h.move(0, 0, use_async=True, maximum_velocity=(1.0,) * 7) == \
        MoveStatus.kMotionStarted
    h.cycle()
    read = int(h.state["message_id"])
    h.cycle(50)  # the program slept meanwhile
    q_start = np.array(h.state["q_d"], dtype=float)
    first, target = q_start.copy(), q_start.copy()
    first[0] -= 0.1
    target[0] += 0.1
    h.send(message_id=read, q_c=first)
    h.send(message_id=read, q_c=target)  # (sent after it: this one counts)
    h.cycle(1000)
    np.testing.assert_allclose(h.state["q_d"], target, atol=1e-9)
    assert h.state["robot_mode"] == RobotMode.kMove


def test_async_motion_needs_a_maximum_velocity():
    assert Harness().move(0, 0, use_async=True) == MoveStatus.kInvalidArgumentRejected


def test_a_second_motion_is_refused_while_one_runs():
    h = running_velocity_motion()
    assert h.move(0, 0) == MoveStatus.kCommandNotPossibleRejected


def test_stop_move_preempts_the_motion_and_is_always_answered():
    h = running_velocity_motion()
    replies = h.core.request_stop(8)
    from support.harness import reply_status

    assert [reply_status(r) for r in replies] == [
        (Command.Move, 5, MoveStatus.kPreempted), (Command.StopMove, 8, 0)]
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kIdle
    assert [reply_status(r) for r in h.core.request_stop(9)] == [(Command.StopMove, 9, 0)]


def test_torque_commands_repeat_through_a_gap():
    h = Harness()
    assert h.move(2, 4) == MoveStatus.kMotionStarted
    h.cycle()
    h.send(tau_J_d=np.full(7, 0.5))
    h.cycle()
    h.cycle(3)
    np.testing.assert_allclose(h.state["tau_J_d"], 0.5)


def test_same_commands_from_the_same_start_give_bit_identical_states():
    def run(idle_cycles):
        h = Harness()
        h.cycle(idle_cycles)  # how long the arm idled first must not matter
        h.move(0, 1)
        h.cycle()
        for k in range(300):
            h.send(dq_c=np.full(7, 0.3 * np.sin(k / 50.0)))
            h.cycle()
        return np.array(h.state["q"]), np.array(h.state["tau_J"])

    a, b = run(3), run(250)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def test_a_command_before_the_modes_flip_is_ignored_with_a_log_line(caplog):
    """kMotionStarted is not yet a running motion: a datagram sent before the first state that
    shows the new modes answers nothing and never reaches the generator."""
    h = Harness()
    assert h.move(0, 1) == MoveStatus.kMotionStarted
    with caplog.at_level(logging.INFO, logger="franka_sim.robot.fci"):
        assert not h.send(dq_c=np.full(7, 0.5))
        assert not h.send(dq_c=np.full(7, 0.5))  # one line, not one per datagram
    assert [r.getMessage() for r in caplog.records] == [
        f"RobotCommand for message_id {int(h.state['message_id'])} ignored: no motion is "
        "running (1 so far)"]
    h.cycle(2)
    assert h.state["robot_mode"] == RobotMode.kMove
    assert not np.asarray(h.state["dq_d"]).any()


def test_each_client_gets_its_first_stray_command_logged(caplog):
    h = Harness()
    with caplog.at_level(logging.INFO, logger="franka_sim.robot.fci"):
        h.core.client_connected()
        assert not h.send(dq_c=np.zeros(7))
        h.core.client_gone()
        h.core.client_connected()  # the next client
        assert not h.send(dq_c=np.zeros(7))
    assert [r.getMessage().endswith("(1 so far)") for r in caplog.records] == [True, True]


@pytest.mark.parametrize("kwargs, what", [
    (dict(deviation=(np.nan, 3.12, 6.28)), "a NaN path deviation"),
    (dict(deviation=(10.0, -1.0, 6.28)), "a negative path deviation"),
    (dict(use_async=True, maximum_velocity=(np.nan,) * 7), "a NaN maximum velocity"),
    (dict(use_async=True, maximum_velocity=(1.0,) * 7, generator=1), "an async velocity motion"),
    (dict(use_async=True, maximum_velocity=(1.0,) * 7, controller=2),
     "an async motion under an external controller"),
])
def test_invalid_move_arguments_are_rejected_as_invalid_arguments(kwargs, what):
    kwargs = dict(kwargs)
    args = (kwargs.pop("controller", 0), kwargs.pop("generator", 0))
    h = Harness()
    assert h.move(*args, **kwargs) == MoveStatus.kInvalidArgumentRejected, what
    assert h.move(0, 0) == MoveStatus.kMotionStarted  # nothing was left half-started


def test_recovery_waits_for_the_arm_to_come_to_rest():
    h = running_velocity_motion(enforce_comm_constraints=True)
    for k in range(1, 301):  # up to 0.3 rad/s at 1 rad/s²
        h.send(dq_c=np.full(7, 0.001 * k))
        h.cycle()
    h.cycle(20)  # the client fell silent: the reflex
    assert h.state["robot_mode"] == RobotMode.kReflex
    assert np.max(np.abs(h.state["dq"])) > 0.05  # still braking
    assert h.core.request_recovery(9) == []
    assert h.core.request_recovery(10) == []  # asked twice (a raw client): both answered
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kAutomaticErrorRecovery
    assert h.statuses() == [(Command.Move, 5, MoveStatus.kReflexAborted)]
    cycles = 0
    while h.state["robot_mode"] == RobotMode.kAutomaticErrorRecovery:
        assert np.max(np.abs(h.state["dq"])) >= 1e-3
        h.cycle()
        cycles += 1
    assert 10 < cycles < 700  # it waited for the arm, not for the 0.7 s bound
    assert h.state["robot_mode"] == RobotMode.kIdle and not h.state["errors"].any()
    assert h.statuses() == [(Command.AutomaticErrorRecovery, 9, AER.kSuccess),
                            (Command.AutomaticErrorRecovery, 10, AER.kSuccess)]


def test_replies_taken_before_a_later_reply_stay_as_they_were():
    """A cycle with no robot reply but a tool's state keeps what it took (arm_cycle.complete);
    in lockstep's settling it goes out together with later cycles' replies (Replies.then). A
    Move's final status answered in a later cycle must go out once, not also with the earlier
    cycle's (the live list once was handed out: a duplicate kSuccess on the wire)."""
    from franka_sim.robot.cycle import Replies
    from franka_sim.robot.status import RobotStatus

    status = RobotStatus()
    earlier = Replies(status.take_replies(), (([], b"a tool state"),))
    status.answer_move(4, MoveStatus.kSuccess)
    later = Replies(status.take_replies())
    assert earlier.robot == [] and len(later.robot) == 1
    assert len(earlier.then(later).robot) == 1
