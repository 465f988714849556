"""Motion-limit checking, one test per error the checker raises: a crafted stream that trips
it, and what the violation names (sans-IO, as tests/robot/test_safety.py).

Figures come from tests/data/fr3_limits.md and docs/figures.md ("Joint and Cartesian limits"),
error names from protocol_specs/robot_v10.md ("Error bits").
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.robot.checks import RAISED_ERRORS, check_measured

from support.checker_streams import (
    CART, DESC, DT, ELBOW_HOME, HOME, JP, JV, T_HOME, cartesian_checker, column_major, command,
    fields, joint_checker, names, pose, pose_commands, ramp, run,
)


# -- one test per error the checker raises --------------------------------------------------------
def test_raises_joint_motion_generator_position_limits_violation():
    # All-zero q_c (a zero-filled command): joints 4 and 6 have ranges that exclude 0.
    reported = run(joint_checker(), [command(q_c=HOME)] * 3 + [command(q_c=np.zeros(7))])
    limits = [v for _, v in reported if v.name == JP + "position_limits_violation"]
    assert [(v.axis, v.value, v.limit) for v in limits] == [("joint 4", 0.0, -0.1458),
                                                            ("joint 6", 0.0, 0.54092)]
    assert names(reported) == {JP + "position_limits_violation", JP + "velocity_discontinuity"}


def test_all_zero_q_c_as_the_first_command_is_out_of_range_and_not_the_start_pose():
    reported = run(joint_checker(), [command(q_c=np.zeros(7))])
    assert names(reported) == {JP + "position_limits_violation",
                               "joint_position_motion_generator_start_pose_invalid"}


def test_raises_joint_motion_generator_velocity_limits_violation():
    q1, _ = ramp(2.8, 0.6, 0.1)  # smoothly to 2.8 rad/s > 2.62
    stream = [command(q_c=np.r_[x, HOME[1:]]) for x in q1]
    reported = run(joint_checker(), stream)
    assert names(reported) == {JP + "velocity_limits_violation"}
    first = reported[0][1]
    assert first.axis == "joint 1" and first.limit == 2.62 and 2.62 < first.value < 2.63
    _, dq1 = ramp(2.8, 0.6, 0.1)
    stream = [command(dq_c=np.r_[v, 0, 0, 0, 0, 0, 0]) for v in dq1]
    reported = run(joint_checker(Gen.kJointVelocity), stream)
    assert names(reported) == {JV + "velocity_limits_violation"}


def test_the_joint_velocity_limit_shrinks_toward_a_range_end():
    # Joint 4 cruising up at 1 rad/s: the law allows √(2·4·gap) − 0.3, which drops below
    # 1 rad/s about 0.21 rad before the upper end (−0.1458), long before the range is left.
    q4, _ = ramp(1.0, 0.4, 2.0, start=-1.5)
    stream = [command(q_c=np.r_[HOME[:3], x, HOME[4:]]) for x in q4]
    k, first = run(joint_checker(q_start=np.r_[HOME[:3], -1.5, HOME[4:]]), stream)[0]
    assert first.name == JP + "velocity_limits_violation" and first.axis == "joint 4"
    assert first.limit < 1.0 and -0.36 < q4[k] < -0.35


def test_a_stream_riding_the_envelope_like_libfrankas_limiter_passes():
    # Command min(1 rad/s, law(q) − 1e-3) toward joint 4's upper end, as libfranka's limiter does.
    q4 = -1.5
    lower, upper = DESC.joints[3].limits.lower, DESC.joints[3].limits.upper
    stream = []
    for k in range(1, 3000):
        law = min(2.62, max(0.0, -0.3 + math.sqrt(max(0.0, 8.0 * (upper - q4)))))
        v = min(0.5 * (1 - math.cos(math.pi * min(k, 400) / 400)), law - 1e-3)
        q4 += v * DT
        stream.append(command(q_c=np.r_[HOME[:3], q4, HOME[4:]]))
    assert lower < q4 < upper - 0.01
    assert run(joint_checker(q_start=np.r_[HOME[:3], -1.5, HOME[4:]]), stream) == []


def test_raises_joint_motion_generator_velocity_discontinuity():
    # A 1 mrad step in q_c: 1 rad/s reached within one cycle.
    stream = [command(q_c=HOME)] * 5 + [command(q_c=HOME + np.r_[0, 0, 0, 1e-3, 0, 0, 0])] * 5
    k, first = run(joint_checker(), stream)[0]
    assert (k, first.name, first.axis) == (5, JP + "velocity_discontinuity", "joint 4")
    assert first.describe() == (
        "joint_motion_generator_velocity_discontinuity: joint 4 acceleration 1000 rad/s² > 10")
    # It jumps back to rest after a cycle, and its acceleration jumps back to 0 after another.
    assert names(run(joint_checker(), stream)) == {JP + "velocity_discontinuity",
                                                   JP + "acceleration_discontinuity"}


def test_raises_joint_motion_generator_acceleration_discontinuity():
    # q_c: 8 rad/s² (inside 10) switched on within one cycle, i.e. jerk 8000 > 5000.
    t = np.arange(1, 100) * DT
    stream = [command(q_c=HOME + np.r_[4 * t_ * (t_ + DT), 0, 0, 0, 0, 0, 0]) for t_ in t]
    reported = run(joint_checker(), stream)
    assert [(k, v.name, v.quantity) for k, v in reported] == [
        (0, JP + "acceleration_discontinuity", "jerk")]
    # dq_c: a step in velocity is an *acceleration* discontinuity on this interface.
    stream = [command(dq_c=np.zeros(7))] * 3 + [command(dq_c=np.r_[0.05, 0, 0, 0, 0, 0, 0])]
    reported = run(joint_checker(Gen.kJointVelocity), stream)
    assert names(reported) == {JV + "acceleration_discontinuity"}


def test_a_discontinuity_wins_over_the_velocity_limit_it_also_breaks():
    step = [command(q_c=HOME)] * 3 + [command(q_c=HOME + np.r_[0.01, 0, 0, 0, 0, 0, 0])]
    reported = run(joint_checker(), step)  # 10 rad/s > 2.62 as well, but it is a jump
    assert [v.name for _, v in reported] == [JP + "velocity_discontinuity"]
    jump = [command(dq_c=np.zeros(7))] * 3 + [command(dq_c=np.r_[3.0, 0, 0, 0, 0, 0, 0])]
    assert [v.name for _, v in run(joint_checker(Gen.kJointVelocity), jump)] == [
        JV + "acceleration_discontinuity"]
    twist = [command(O_dP_EE_c=np.zeros(6))] * 3 + [command(O_dP_EE_c=np.r_[3.5, 0, 0, 0, 0, 0])]
    assert [v.name for _, v in run(cartesian_checker(Gen.kCartesianVelocity), twist)] == [
        CART + "acceleration_discontinuity"]


def test_raises_joint_position_motion_generator_start_pose_invalid():
    reported = run(joint_checker(), [command(q_c=HOME + np.r_[0, 0.1, 0, 0, 0, 0, 0])])
    assert [(v.name, v.axis) for _, v in reported] == [
        ("joint_position_motion_generator_start_pose_invalid", "joint 2")]


def test_the_first_command_is_differenced_from_rest_at_the_start_pose():
    # Within the start tolerance is not "free": 0.1 mrad off in one cycle is a jump.
    reported = run(joint_checker(), [command(q_c=HOME + 1e-4)])
    assert names(reported) == {JP + "velocity_discontinuity"}
    # The float32 copy of q the state carried is the start pose as far as anyone can tell.
    echoed = HOME.astype(np.float32).astype(float)
    assert run(joint_checker(), [command(q_c=echoed)] * 10) == []


def test_raises_cartesian_position_motion_generator_start_pose_invalid():
    name = "cartesian_position_motion_generator_start_pose_invalid"
    for P, axis in ((pose((0.005, 0, 0)), "translation"), (pose(angle=0.01), "rotation")):
        reported = run(cartesian_checker(), pose_commands([P]))
        assert [(v.name, v.axis) for _, v in reported] == [(name, axis)]


def test_a_cartesian_stream_may_start_from_the_float32_pose_the_state_carried():
    echoed = T_HOME.astype(np.float32).astype(float)
    assert run(cartesian_checker(), pose_commands([echoed] * 10)) == []


def test_raises_cartesian_motion_generator_start_elbow_invalid():
    stream = [command(O_T_EE_c=column_major(T_HOME), elbow_c=[ELBOW_HOME[0] + 0.1, ELBOW_HOME[1]],
                      valid_elbow=True)]
    assert names(run(cartesian_checker(), stream)) == {CART + "start_elbow_invalid"}


def test_raises_start_elbow_sign_inconsistent():
    stream = [command(O_T_EE_c=column_major(T_HOME), elbow_c=[ELBOW_HOME[0], -ELBOW_HOME[1]],
                      valid_elbow=True)]
    assert names(run(cartesian_checker(), stream)) == {"start_elbow_sign_inconsistent"}


def test_raises_cartesian_motion_generator_velocity_limits_violation():
    x, _ = ramp(3.2, 1.0, 0.1)
    reported = run(cartesian_checker(), pose_commands(pose((d, 0, 0)) for d in x))
    too_fast = CART + "velocity_limits_violation"
    assert set(fields(reported, "name", "axis")) == {(too_fast, "translation")}
    a, _ = ramp(2.7, 0.5, 0.1)
    reported = run(cartesian_checker(), pose_commands(pose(angle=r) for r in a))
    assert set(fields(reported, "name", "axis")) == {(too_fast, "rotation")}
    _, v = ramp(3.2, 1.0, 0.1)
    stream = [command(O_dP_EE_c=np.r_[0, s, 0, 0, 0, 0]) for s in v]
    assert names(run(cartesian_checker(Gen.kCartesianVelocity), stream)) == {
        CART + "velocity_limits_violation"}


def test_raises_cartesian_motion_generator_velocity_discontinuity():
    for step in (pose((0, 0, 1e-3)), pose(angle=2e-3)):  # 1 mm, 2 mrad
        reported = run(cartesian_checker(), pose_commands([T_HOME] * 5 + [step] * 3))
        assert (reported[0][0], reported[0][1].name) == (5, CART + "velocity_discontinuity")


def test_raises_cartesian_motion_generator_acceleration_discontinuity():
    # Pose: 8 m/s² (< 9) switched on within one cycle, i.e. jerk 8000 > 4500.
    t = np.arange(1, 50) * DT
    reported = run(cartesian_checker(), pose_commands(pose((4 * s * (s + DT), 0, 0)) for s in t))
    assert [(k, v.name, v.quantity) for k, v in reported] == [
        (0, CART + "acceleration_discontinuity", "jerk")]
    # Twist: a 0.1 rad/s step in angular velocity.
    stream = [command(O_dP_EE_c=np.zeros(6))] * 2 + [command(O_dP_EE_c=np.r_[0, 0, 0, 0, 0.1, 0])]
    reported = run(cartesian_checker(Gen.kCartesianVelocity), stream)
    assert fields(reported, "name", "axis") == [(CART + "acceleration_discontinuity", "rotation")]


def test_raises_cartesian_motion_generator_elbow_limit_violation():
    def stream(elbows):
        return [command(O_T_EE_c=column_major(T_HOME), elbow_c=[e, ELBOW_HOME[1]], valid_elbow=True)
                for e in elbows]
    e, _ = ramp(2.8, 0.6, 0.1, start=ELBOW_HOME[0])  # smoothly over 2.62 rad/s
    reported = run(cartesian_checker(), stream(e))
    elbow_limit = CART + "elbow_limit_violation"
    assert set(fields(reported, "name", "quantity")) == {(elbow_limit, "velocity")}
    reported = run(cartesian_checker(), stream([ELBOW_HOME[0]] * 3 + [ELBOW_HOME[0] + 0.01]))
    assert fields(reported, "name", "quantity") == [(elbow_limit, "acceleration")]


def test_raises_cartesian_motion_generator_elbow_sign_inconsistent():
    flips = [ELBOW_HOME[1]] * 3 + [-ELBOW_HOME[1]] * 3
    stream = [command(O_T_EE_c=column_major(T_HOME), elbow_c=[ELBOW_HOME[0], s], valid_elbow=True)
              for s in flips]
    reported = run(cartesian_checker(), stream)
    assert [(k, v.name) for k, v in reported] == [(3, CART + "elbow_sign_inconsistent")]
    assert reported[0][1].describe().endswith("elbow sign 1 ≠ -1")


@pytest.mark.parametrize("what", ["zero-filled", "scaled", "last row", "mirrored", "sheared"])
def test_raises_cartesian_position_motion_generator_invalid_frame(what):
    bad = T_HOME.copy()
    if what == "zero-filled":
        bad[:] = 0.0
    elif what == "scaled":
        bad[:3, :3] *= 1.01
    elif what == "last row":
        bad[3, 0] = 0.1
    elif what == "mirrored":
        bad[:3, 0] *= -1
    else:
        leaning = bad[:3, 1] + 0.01 * bad[:3, 0]  # unit columns, but not orthogonal
        bad[:3, 1] = leaning / np.linalg.norm(leaning)
    reported = run(cartesian_checker(), pose_commands([T_HOME, bad, T_HOME, T_HOME]))
    assert [(k, v.name) for k, v in reported] == [
        (1, "cartesian_position_motion_generator_invalid_frame")]


def test_raises_controller_torque_discontinuity():
    taus = [np.zeros(7)] * 3 + [np.r_[0, 0, 0, 0, 5.0, 0, 0]]  # 5 Nm in 1 ms
    reported = run(joint_checker(Gen.kNone, torque=True), [command(tau_J_d=t) for t in taus])
    assert [(v.name, v.axis, v.value) for _, v in reported] == [
        ("controller_torque_discontinuity", "joint 5", pytest.approx(5000.0))]
    ramp = [np.full(7, 0.95 * min(k, 10)) for k in range(1, 50)]  # 950 Nm/s to 9.5 Nm passes
    assert run(joint_checker(Gen.kNone, torque=True), [command(tau_J_d=t) for t in ramp]) == []


def test_raises_tau_J_range_violation_as_recommended_only():
    ramp = [np.r_[min(90.0, 0.9 * k), 0, 0, 0, 0, 0, 0] for k in range(1, 200)]  # 900 Nm/s to 90
    reported = run(joint_checker(Gen.kNone, torque=True), [command(tau_J_d=t) for t in ramp])
    assert {(v.name, v.axis, v.limit, v.aborts) for _, v in reported} == {
        ("tau_J_range_violation", "joint 1", 87.0, False)}


def test_raises_joint_velocity_violation():
    assert check_measured(DESC, HOME, np.zeros(7)) == []
    fast = check_measured(DESC, HOME, np.r_[2.7, 0, 0, 0, 0, 0, 0])
    assert [(v.name, v.axis, v.limit) for v in fast] == [
        ("joint_velocity_violation", "joint 1", 2.62)]
    # Near joint 4's upper end the law allows nothing toward it, but noise is not a violation.
    near_end = np.r_[HOME[:3], -0.155, HOME[4:]]  # past −0.1571, where the law reaches 0
    assert check_measured(DESC, near_end, np.r_[0, 0, 0, 0.005, 0, 0, 0]) == []
    assert check_measured(DESC, near_end, np.r_[0, 0, 0, -0.5, 0, 0, 0]) == []  # moving away
    [toward] = check_measured(DESC, near_end, np.r_[0, 0, 0, 0.3, 0, 0, 0])
    assert (toward.name, toward.axis, toward.limit) == ("joint_velocity_violation", "joint 4", 0.0)


def test_raises_joint_position_limits_violation():
    beyond = np.r_[HOME[:5], 4.6, HOME[6]]
    [v] = check_measured(DESC, beyond, np.zeros(7))
    assert (v.name, v.axis, v.limit) == ("joint_position_limits_violation", "joint 6", 4.5205)


def test_every_error_the_checker_raises_has_its_own_test():
    tests = {name for name in dir(sys.modules[__name__]) if name.startswith("test_raises_")}
    assert tests == {f"test_raises_{name}" if name != "tau_J_range_violation"
                     else "test_raises_tau_J_range_violation_as_recommended_only"
                     for name in RAISED_ERRORS}
