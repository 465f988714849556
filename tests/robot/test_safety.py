"""Motion-limit checking, as a specification: which command streams the robot refuses, and how
it names them (sans-IO: crafted RobotCommand records in, Violations out, no server).

Figures come from tests/data/fr3_limits.md and docs/figures.md ("Joint and Cartesian limits"),
error names from protocol_specs/robot_v10.md ("Error bits"). Streams are built at 1 ms cycles;
`cycles` > 1 means the server saw that many cycles between two applied commands.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.robot.checks import Violation

from support.checker_streams import (
    CART, DT, ELBOW_HOME, HOME, JP, T_HOME, cartesian_checker, column_major, command,
    joint_checker, joint_quintic, names, pose, pose_commands, ramp, run,
)


# -- smooth streams pass --------------------------------------------------------------------------
def test_a_quintic_joint_move_at_95_percent_of_the_acceleration_limit_passes():
    assert run(joint_checker(), [command(q_c=q) for q in joint_quintic(0.95)]) == []


def test_the_same_move_at_105_percent_trips_a_velocity_discontinuity():
    reported = run(joint_checker(), [command(q_c=q) for q in joint_quintic(1.05)])
    assert names(reported) == {JP + "velocity_discontinuity"}
    assert {v.axis for _, v in reported} == {"joint 1", "joint 4"}
    assert all(10.0 < v.value < 10.6 and v.limit == 10.0 for _, v in reported)


def test_a_libfranka_style_cosine_joint_position_motion_passes():
    # Joints 4, 5 and 7 swing by π/8·(1 − cos(π t / 2.5)) for 5 s.
    t = np.arange(1, 5001) * DT
    delta = math.pi / 8 * (1 - np.cos(math.pi / 2.5 * t))
    q = np.tile(HOME, (len(t), 1))
    q[:, [3, 4, 6]] += delta[:, None]
    assert run(joint_checker(), [command(q_c=x) for x in q]) == []


def test_a_libfranka_style_cosine_joint_velocity_motion_passes():
    # Joints 4–7 follow a 1 s cosine bump of 1 rad/s peak, alternating sign each second.
    t = np.arange(1, 4001) * DT
    omega = (-1.0) ** np.floor(t) * 0.5 * (1 - np.cos(2 * math.pi * t))
    dq = np.zeros((len(t), 7))
    dq[:, 3:] = omega[:, None]
    assert run(joint_checker(Gen.kJointVelocity), [command(dq_c=x) for x in dq]) == []


def test_libfranka_style_cartesian_pose_and_elbow_motions_pass():
    # Translation along an arc of 0.3 m radius, angle π/4·(1 − cos(π t / 5)); elbow swings too.
    t = np.arange(1, 10001) * DT
    arc = math.pi / 4 * (1 - np.cos(math.pi / 5 * t))
    poses = [pose((0.3 * math.sin(a), 0.0, 0.3 * (math.cos(a) - 1)), angle=a / 4) for a in arc]
    elbows = ELBOW_HOME[0] + 0.2 * (1 - np.cos(math.pi / 5 * t))
    commands = [command(O_T_EE_c=column_major(P), elbow_c=[e, ELBOW_HOME[1]], valid_elbow=True)
                for P, e in zip(poses, elbows)]
    assert run(cartesian_checker(), commands) == []


def test_a_libfranka_style_cartesian_velocity_motion_passes():
    # A 4 s cosine speed bump of 0.1 m/s along (x, −z)/√2, and a slow twist about z.
    t = np.arange(1, 4001) * DT
    speed = 0.05 * (1 - np.cos(2 * math.pi / 4 * t))
    twists = np.zeros((len(t), 6))
    twists[:, 0], twists[:, 2], twists[:, 5] = speed / math.sqrt(2), -speed / math.sqrt(2), speed
    stream = [command(O_dP_EE_c=w) for w in twists]
    assert run(cartesian_checker(Gen.kCartesianVelocity), stream) == []


def test_cartesian_speed_bumps_at_95_percent_of_the_velocity_limits_pass():
    # v(t) = V/2·(1 − cos(2π t/T)) peaks at V with acceleration πV/T and jerk 2π²V/T².
    t = np.arange(1, 2001) * DT
    bump = 0.5 * (1 - np.cos(math.pi * t))  # T = 2 s
    x = np.cumsum(0.95 * 3.0 * bump) * DT
    angle = np.cumsum(0.95 * 2.5 * bump) * DT
    inside = pose_commands(pose((d, 0, 0), a) for d, a in zip(x, angle))
    assert run(cartesian_checker(), inside) == []
    too_fast = run(cartesian_checker(), pose_commands(pose((1.07 * d, 0, 0)) for d in x))
    assert names(too_fast) == {CART + "velocity_limits_violation"}


# -- late datagrams and the stale-resume trap ---------------------------------------------------
def _with_stalls(samples, stall, every=37):
    """Lose `stall` samples after every `every`-th kept one; the next is applied stall+1 cycles
    after its predecessor, and is the trajectory's waypoint for that time (the client's clock
    is the state's, which kept running)."""
    kept, cycles, k, gap = [], [], 0, 1
    while k < len(samples):
        kept.append(samples[k])
        cycles.append(gap)
        gap = stall + 1 if len(kept) % every == 0 else 1
        k += gap
    return kept, cycles


@pytest.mark.parametrize("stall", range(1, 12))
def test_bursts_of_late_datagrams_on_a_smooth_joint_stream_pass(stall):
    samples, cycles = _with_stalls(joint_quintic(0.95), stall)
    assert max(cycles) == stall + 1
    assert run(joint_checker(), [command(q_c=q) for q in samples], cycles) == []


@pytest.mark.parametrize("stall", [1, 4, 11])
def test_bursts_of_late_datagrams_pass_on_every_interface(stall):
    t = np.arange(1, 1501) * DT
    bump = 0.5 * (1 - np.cos(2 * math.pi * t / 1.5))
    dq, dq_cycles = _with_stalls([np.r_[0, 0, 0, 2.4 * b, 0, 0, 0] for b in bump], stall)
    assert run(joint_checker(Gen.kJointVelocity), [command(dq_c=x) for x in dq], dq_cycles) == []
    x = np.cumsum(2.8 * bump) * DT
    poses, pose_cycles = _with_stalls([pose((d, 0, 0), 0.8 * d) for d in x], stall)
    assert run(cartesian_checker(), pose_commands(poses), pose_cycles) == []
    twists, twist_cycles = _with_stalls([np.r_[2.8 * b, 0, 0, 0, 0, 2.2 * b] for b in bump],
                                        stall)
    stream = [command(O_dP_EE_c=w) for w in twists]
    assert run(cartesian_checker(Gen.kCartesianVelocity), stream, twist_cycles) == []


def test_late_samples_are_differenced_over_the_time_between_them():
    # Constant 10.5 rad/s² on joint 1, with samples lost at random: every cycle that reports it
    # reports 10.5 — not (n+1)/2 times that on the first regular cycle after n lost ones.
    rng = np.random.default_rng(3)
    cycles = [1] + list(rng.choice([1, 1, 1, 2, 5, 12], size=150))
    t = np.cumsum(cycles) * DT
    stream = [command(q_c=HOME + np.r_[5.25 * s * (s + DT), 0, 0, 0, 0, 0, 0]) for s in t]
    reported = run(joint_checker(), stream, cycles)
    accelerations = [v.value for _, v in reported if v.quantity == "acceleration"]
    assert len(accelerations) == len(stream) and np.allclose(accelerations, 10.5)


@pytest.mark.parametrize("gap", [1, 3, 10, 19])
def test_resuming_from_the_own_stale_waypoint_after_a_gap_trips_a_discontinuity(gap):
    # The client goes quiet for `gap` cycles, then carries on with the waypoint it would have
    # sent next as if no time had passed: a real jump, so it trips as it would on hardware.
    q = joint_quintic(0.5)
    k = len(q) // 2  # mid-move, ~1.3 rad/s
    commands = [command(q_c=x) for x in q[:k]] + [command(q_c=x) for x in q[k:k + 50]]
    reported = run(joint_checker(), commands, [1] * k + [gap + 1] + [1] * 49)
    assert (reported[0][0], reported[0][1].name) == (k, JP + "velocity_discontinuity")
    assert names(reported) <= {JP + "velocity_discontinuity", JP + "acceleration_discontinuity"}


def test_resuming_a_cartesian_pose_stream_from_a_stale_waypoint_trips_too():
    x, _ = ramp(1.0, 0.3, 0.3)  # smoothly to 1 m/s
    commands = pose_commands(pose((d, 0, 0)) for d in x)
    reported = run(cartesian_checker(), commands, [1] * 400 + [6] + [1] * 199)
    assert (reported[0][0], reported[0][1].name) == (400, CART + "velocity_discontinuity")


# -- only the active signal is judged -------------------------------------------------------------
GARBAGE = dict(q_c=np.zeros(7), dq_c=np.full(7, 99.0), O_T_EE_c=np.full(16, 7.0),
               O_dP_EE_c=np.full(6, 99.0), elbow_c=[42.0, 0.0], tau_J_d=np.full(7, 999.0))


def _over(field, values, **extra):
    return [command(**{**GARBAGE, field: v, **extra}) for v in values]


def test_a_joint_motion_ignores_every_other_field():
    q = joint_quintic(0.5)
    assert run(joint_checker(), _over("q_c", q)) == []
    stream = _over("dq_c", [np.zeros(7)] * 100)
    assert run(joint_checker(Gen.kJointVelocity), stream) == []


def test_a_cartesian_motion_ignores_q_c_and_an_elbow_it_does_not_command():
    assert run(cartesian_checker(), _over("O_T_EE_c", [column_major(T_HOME)] * 50)) == []
    stream = _over("O_dP_EE_c", [np.zeros(6)] * 50)
    assert run(cartesian_checker(Gen.kCartesianVelocity), stream) == []


def test_a_torque_only_motion_judges_tau_J_d_alone():
    checker = joint_checker(Gen.kNone, torque=True, q_start=None)
    assert run(checker, _over("tau_J_d", [np.zeros(7)] * 50)) == []


def test_under_the_external_controller_both_the_generator_and_tau_J_d_are_judged():
    stream = [command(q_c=HOME, tau_J_d=np.zeros(7))] * 3 + [
        command(q_c=HOME + np.r_[1e-3, 0, 0, 0, 0, 0, 0], tau_J_d=np.r_[0, 0, 10.0, 0, 0, 0, 0])]
    assert names(run(joint_checker(torque=True), stream)) == {
        JP + "velocity_discontinuity", "controller_torque_discontinuity"}
    garbage_tau = [command(q_c=HOME, tau_J_d=np.full(7, 50.0))]
    assert run(joint_checker(torque=False), garbage_tau) == []  # no external controller: ignored


# -- the API ---------------------------------------------------------------------------------------
def test_violations_name_real_error_bits_and_describe_themselves_in_one_line():
    with pytest.raises(KeyError):
        Violation("joint_velocity_violaton", "joint 1", 3.0, 2.62)
    v = Violation("joint_position_limits_violation", "joint 4", -3.1, -3.0481,
                  quantity="measured position", unit="rad")
    assert v.aborts and v.describe() == (
        "joint_position_limits_violation: joint 4 measured position -3.1 rad < -3.0481")


def test_cycles_must_be_a_positive_interval():
    with pytest.raises(ValueError):
        joint_checker().check(command(q_c=HOME), 0)
