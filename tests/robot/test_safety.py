"""Motion-limit checking, as a specification: which command streams the robot refuses, and how
it names them (sans-IO: crafted RobotCommand records in, Violations out, no server).

Figures come from tests/data/fr3_limits.md and docs/figures.md ("Joint and Cartesian limits"),
error names from protocol_specs/robot_v10.md ("Error bits"). Streams are built at 1 ms cycles;
`cycles` > 1 means the server saw that many cycles between two applied commands.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from franka_sim.description.kinematics import elbow, flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.protocol.codec import decode_command, encode_command
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.robot.checks import RAISED_ERRORS, Violation, check_measured, command_checker_for

DESC = load_arm_description(default_urdf_text())
DT = 1e-3
HOME = np.array([0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4])
T_HOME = flange_pose(DESC, HOME)
ELBOW_HOME = elbow(HOME)  # (joint-3 angle, flip sign −1 at this pose)

JP = JV = "joint_motion_generator_"  # (position / velocity interface, for readability)
CART = "cartesian_motion_generator_"


def column_major(T) -> np.ndarray:
    return np.asarray(T).ravel(order="F")


def command(**fields):
    """A RobotCommand exactly as the server decodes it: every other field zero."""
    return decode_command(encode_command(**fields))


def joint_checker(generator=Gen.kJointPosition, torque=False, q_start=HOME):
    return command_checker_for(DESC, generator, torque, q_start=q_start, O_T_EE_start=None,
                               elbow_start=None)


def cartesian_checker(generator=Gen.kCartesianPosition, torque=False, elbow=ELBOW_HOME):
    return command_checker_for(DESC, generator, torque, q_start=HOME, O_T_EE_start=T_HOME,
                               elbow_start=elbow)


def run(checker, commands, cycles=None) -> list[tuple[int, Violation]]:
    """Feed a stream; (index, violation) for everything reported."""
    cycles = cycles or [1] * len(commands)
    return [(k, v) for k, (c, n) in enumerate(zip(commands, cycles)) for v in checker.check(c, n)]


def names(reported) -> set[str]:
    return {v.name for _, v in reported}


def fields(reported, *attributes) -> list[tuple]:
    """The chosen attributes of each reported violation, in order."""
    return [tuple(getattr(v, a) for a in attributes) for _, v in reported]


# -- profiles ---------------------------------------------------------------------------------
def quintic(t, duration):
    """Rest-to-rest 0→1 with zero velocity and acceleration at both ends; peak ä = 5.7735/T²."""
    s = np.clip(np.asarray(t, dtype=float) / duration, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def quintic_duration(distance, peak_acceleration):
    return math.sqrt(5.773502691896258 * distance / peak_acceleration)


def joint_quintic(fraction=0.95, distance=1.0, joints=(0, 3)):
    """A joint-position stream whose peak acceleration is `fraction` of 10 rad/s² (1 ms cycles)."""
    duration = quintic_duration(distance, 10.0 * fraction)
    t = np.arange(1, int(duration / DT) + 200) * DT
    q = np.tile(HOME, (len(t), 1))
    for i in joints:
        q[:, i] += distance * quintic(t, duration)
    return q


def pose(translation=(0.0, 0.0, 0.0), angle=0.0, T=T_HOME):
    """T_HOME moved by a base-frame translation and a rotation about the base z axis."""
    c, s = math.cos(angle), math.sin(angle)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    out = T.copy()
    out[:3, :3] = Rz @ T[:3, :3]
    out[:3, 3] = T[:3, 3] + np.asarray(translation)
    return out


def pose_commands(poses, **extra):
    return [command(O_T_EE_c=column_major(P), **extra) for P in poses]


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
    x, _ = _ramp(1.0, 0.3, 0.3)  # smoothly to 1 m/s
    commands = pose_commands(pose((d, 0, 0)) for d in x)
    reported = run(cartesian_checker(), commands, [1] * 400 + [6] + [1] * 199)
    assert (reported[0][0], reported[0][1].name) == (400, CART + "velocity_discontinuity")


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


def _ramp(peak, rise, hold, start=0.0):
    """Velocity from rest to `peak` by a half-cosine over `rise` s, then held for `hold` s."""
    t = np.arange(1, int((rise + hold) / DT) + 1) * DT
    v = peak * 0.5 * (1 - np.cos(math.pi * np.minimum(t, rise) / rise))
    return start + np.cumsum(v) * DT, v


def test_raises_joint_motion_generator_velocity_limits_violation():
    q1, _ = _ramp(2.8, 0.6, 0.1)  # smoothly to 2.8 rad/s > 2.62
    stream = [command(q_c=np.r_[x, HOME[1:]]) for x in q1]
    reported = run(joint_checker(), stream)
    assert names(reported) == {JP + "velocity_limits_violation"}
    first = reported[0][1]
    assert first.axis == "joint 1" and first.limit == 2.62 and 2.62 < first.value < 2.63
    _, dq1 = _ramp(2.8, 0.6, 0.1)
    stream = [command(dq_c=np.r_[v, 0, 0, 0, 0, 0, 0]) for v in dq1]
    reported = run(joint_checker(Gen.kJointVelocity), stream)
    assert names(reported) == {JV + "velocity_limits_violation"}


def test_the_joint_velocity_limit_shrinks_toward_a_range_end():
    # Joint 4 cruising up at 1 rad/s: the law allows √(2·4·gap) − 0.3, which drops below
    # 1 rad/s about 0.21 rad before the upper end (−0.1458), long before the range is left.
    q4, _ = _ramp(1.0, 0.4, 2.0, start=-1.5)
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
    x, _ = _ramp(3.2, 1.0, 0.1)
    reported = run(cartesian_checker(), pose_commands(pose((d, 0, 0)) for d in x))
    too_fast = CART + "velocity_limits_violation"
    assert set(fields(reported, "name", "axis")) == {(too_fast, "translation")}
    a, _ = _ramp(2.7, 0.5, 0.1)
    reported = run(cartesian_checker(), pose_commands(pose(angle=r) for r in a))
    assert set(fields(reported, "name", "axis")) == {(too_fast, "rotation")}
    _, v = _ramp(3.2, 1.0, 0.1)
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
    e, _ = _ramp(2.8, 0.6, 0.1, start=ELBOW_HOME[0])  # smoothly over 2.62 rad/s
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
