"""A client that falls silent or goes mid-motion, specified on the sans-IO robot core: the
robot extrapolates its motion for twenty cycles, then brakes the arm to rest; with enforcement
it aborts with communication_constraints_violation, without it only counts the losses. A
client heard again goes on from where the arm was held.
"""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.protocol.enums import (
    AutomaticErrorRecoveryStatus as AER,
    Command,
    MoveStatus,
    RobotMode,
)
from franka_sim.protocol.errors import error_index
from support.harness import Harness, running_velocity_motion

COMM = error_index("communication_constraints_violation")


def _silent_at(speed: float, **kwargs) -> tuple[Harness, np.ndarray]:
    """A joint-velocity motion ramped to `speed` (1 rad/s²) whose client then falls silent (or,
    with `gone`, closes its connection); the measured q of its last answered state."""
    gone = kwargs.pop("gone", False)
    h = running_velocity_motion(**kwargs)
    for dq in np.arange(0.0, speed + 1e-9, 0.001):
        h.send(dq_c=np.full(7, dq))
        h.cycle()
    if gone:
        h.core.client_gone()
    return h, np.array(h.state["q"], dtype=float)


@pytest.mark.parametrize("gone", [False, True], ids=["silent", "connection closed"])
def test_a_lost_client_s_motion_runs_on_twenty_cycles_then_brakes_to_rest(gone):
    """As the robot does: its commands are extrapolated for the 20 cycles it tolerates, then
    its stop decelerates the arm (at most 10 rad/s²: from 0.3 rad/s over ~4.5 mrad), never an
    instant freeze, and the arm is held where it stopped (no springing back)."""
    h, q_last = _silent_at(0.3, gone=gone)
    travel = []
    for _ in range(700):
        h.cycle()
        travel.append(np.asarray(h.state["q"], dtype=float) - q_last)
    travel = np.array(travel)
    np.testing.assert_allclose(travel[19], 0.3 * 0.020, rtol=0.05)  # on at 0.3 rad/s
    assert np.all(np.abs(h.state["dq"]) < 1e-6)  # then at rest,
    stop = travel[-1] - travel[19]
    assert np.all(stop > 0.003) and np.all(stop < 0.008)  # several mrad further: a braking
    assert np.all(travel[-1] >= travel[19:].max(axis=0) - 0.004)  # it stays (little springing)
    if gone:  # nobody to answer: idle at once, and the next client may move at once
        assert h.state["robot_mode"] == RobotMode.kIdle and not h.state["errors"].any()
        assert h.statuses() == []
    else:  # the motion waits for its client
        assert h.state["robot_mode"] == RobotMode.kMove and h.core.client_silent


def test_a_silent_client_heard_again_goes_on_from_where_the_arm_was_braked():
    h, _ = _silent_at(0.1)
    h.cycle(100)
    q_d = np.array(h.state["q_d"], dtype=float)
    assert h.core.client_silent
    h.send(dq_c=np.zeros(7))
    h.cycle()
    assert not h.core.client_silent
    np.testing.assert_allclose(h.state["q_d"], q_d, atol=1e-6)  # float32 on the wire
    assert h.state["robot_mode"] == RobotMode.kMove


def test_a_velocity_stream_heard_again_is_judged_where_the_robot_held_the_arm():
    """A client paused for 4 s at -0.2 rad/s on joint 4 (a debugger), then going on at that
    speed: the robot braked and held the arm, so the stream goes on from there (~0.7 rad from
    joint 4's lower end), not from the 0.8 rad further the paused speed would have taken it
    over the whole gap, past the end, where the velocity law allows 0 rad/s."""
    h = running_velocity_motion(enforce_motion_limits=True)
    on_joint_4 = np.zeros(7)
    for dq in np.arange(0.0, 0.2 + 1e-9, 0.001):
        on_joint_4[3] = -dq
        h.send(dq_c=on_joint_4)
        h.cycle()
    h.cycle(4000)
    assert h.core.client_silent
    held = np.array(h.state["q_d"], dtype=float)
    for _ in range(10):
        h.send(dq_c=on_joint_4)
        h.cycle()
    assert h.state["robot_mode"] == RobotMode.kMove and not h.state["errors"].any()
    assert h.statuses() == []
    np.testing.assert_allclose(h.state["q_d"][3], held[3] - 0.2 * 0.010, atol=1e-5)


def test_twenty_lost_cycles_abort_with_communication_constraints_violation():
    h = running_velocity_motion(enforce_comm_constraints=True)
    h.send(dq_c=np.zeros(7))
    h.cycle()  # closes the answered cycle
    h.cycle(19)
    assert h.state["robot_mode"] == RobotMode.kMove  # 19 lost: still running
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kReflex
    assert h.state["errors"][COMM] and h.state["reflex_reason"][COMM]
    assert (Command.Move, 5, MoveStatus.kReflexAborted) in h.statuses()
    # A Move before recovery is refused as the robot refuses it.
    assert h.move(0, 1) == MoveStatus.kCommandNotPossibleRejected
    assert h.core.request_recovery(9) == []  # answered once the arm is at rest
    h.cycle(3)
    assert (Command.AutomaticErrorRecovery, 9, AER.kSuccess) in h.statuses()
    assert h.state["robot_mode"] == RobotMode.kIdle and not h.state["errors"].any()
    assert h.move(0, 1) == MoveStatus.kMotionStarted


def test_without_enforcement_losses_are_only_counted_and_the_arm_stops():
    h = running_velocity_motion()
    h.send(dq_c=np.full(7, 0.2))  # a jump from rest: 200 rad/s², and 20 cycles extrapolated
    h.cycle()
    h.cycle(1500)  # the client fell silent: braking at 10 rad/s² from where that took the arm
    assert h.state["robot_mode"] == RobotMode.kMove
    assert not h.state["errors"].any()
    assert np.max(np.abs(h.state["dq"])) < 1e-3  # it came to rest instead of running away
    assert h.state["control_command_success_rate"] < 0.05


def test_a_client_gone_mid_motion_under_enforcement_leaves_the_reflex(caplog):
    h = running_velocity_motion(enforce_comm_constraints=True)
    h.send(dq_c=np.zeros(7))
    h.cycle()
    with caplog.at_level("WARNING"):
        h.core.client_gone()
    assert [r.getMessage() for r in caplog.records] == [
        "the client left during its motion: communication_constraints_violation"]
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kReflex
    assert h.state["errors"][COMM] and h.state["reflex_reason"][COMM]
    assert h.move(0, 1) == MoveStatus.kCommandNotPossibleRejected


def test_a_client_gone_mid_motion_without_enforcement_leaves_the_robot_idle():
    h = running_velocity_motion()
    h.send(dq_c=np.zeros(7))
    h.cycle()
    h.core.client_gone()
    h.cycle()
    assert h.state["robot_mode"] == RobotMode.kIdle and not h.state["errors"].any()
    assert h.move(0, 1) == MoveStatus.kMotionStarted
