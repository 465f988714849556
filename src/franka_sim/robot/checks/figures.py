"""Each robot kind's fixed motion limits, the error each one latches, and the checks' slack.

The fixed figures (joint acceleration and jerk, torque rate, the Cartesian translation/rotation/
elbow envelopes) are the datasheet values (tests/data/fr3_limits.md; the Panda's beside them),
which are the *robot's* thresholds; libfranka's client-side rate limiter uses the same figures minus 1e-3
(docs/figures.md, "Joint and Cartesian limits"), so a stream it produced stays inside them. The
per-joint figures come from the served URDF instead (see joint_table.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from franka_sim.protocol.errors import error_index
from franka_sim.protocol.timing import CYCLE_PERIOD

# What libfranka subtracts from every figure below before limiting a stream (rate_limiting.h).
LIBFRANKA_LIMIT_EPS = 1e-3


@dataclass(frozen=True)
class Envelope:
    """Bounds on a signal's first three time derivatives (velocity, acceleration, jerk)."""

    velocity: float
    acceleration: float
    jerk: float


JOINT_ACCELERATION = 10.0  # rad/s², every joint
JOINT_JERK = 5000.0  # rad/s³, every joint
TORQUE_RATE = 1000.0  # Nm/s, every joint
CARTESIAN_TRANSLATION = Envelope(3.0, 9.0, 4500.0)  # m/s, m/s², m/s³
CARTESIAN_ROTATION = Envelope(2.5, 17.0, 8500.0)  # rad/s, rad/s², rad/s³
# The datasheet's 2.62 rad/s, not libfranka's stricter 1.5: the robot's threshold is the datasheet.
ELBOW = Envelope(2.62, 10.0, 5000.0)


@dataclass(frozen=True, eq=False)
class MotionFigures:
    """A robot kind's fixed motion limits; its per-joint range, velocity and torque are its
    URDF's (joint_table.py)."""

    joint_acceleration: np.ndarray  # (7,) rad/s²
    joint_jerk: np.ndarray  # (7,) rad/s³
    translation: Envelope  # m/s, m/s², m/s³
    rotation: Envelope  # rad/s, rad/s², rad/s³
    elbow: Envelope  # rad/s, rad/s², rad/s³


FR3 = MotionFigures(np.full(7, JOINT_ACCELERATION), np.full(7, JOINT_JERK),
                    CARTESIAN_TRANSLATION, CARTESIAN_ROTATION, ELBOW)
# The Panda's (FER) datasheet: per-joint acceleration and jerk, its own Cartesian envelopes.
FER = MotionFigures(np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]),
                    np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0]),
                    Envelope(1.7, 13.0, 6500.0), Envelope(2.5, 25.0, 12500.0),
                    Envelope(2.175, 10.0, 5000.0))


def motion_figures(desc) -> MotionFigures:
    """The figures of the robot a description names (`<robot name="fer">`: the Panda's);
    any other description, a user's own too, is held to the FR3's."""
    return FER if desc.name == "fer" else FR3


# -- the error each limit latches (protocol_specs/robot_v10.md, "Error bits") ---------------------
@dataclass(frozen=True)
class ErrorNames:
    """The errors a signal's velocity, acceleration and jerk latch when over their limits.

    The name follows the interface, not the derivative: a step in q_c is a velocity
    discontinuity, the same step in dq_c an acceleration discontinuity.
    """

    velocity: str
    acceleration: str
    jerk: str


_JMG, _CMG = "joint_motion_generator_", "cartesian_motion_generator_"
JOINT_POSITION_NAMES = ErrorNames(velocity=f"{_JMG}velocity_limits_violation",
                                  acceleration=f"{_JMG}velocity_discontinuity",
                                  jerk=f"{_JMG}acceleration_discontinuity")
JOINT_VELOCITY_NAMES = ErrorNames(velocity=f"{_JMG}velocity_limits_violation",
                                  acceleration=f"{_JMG}acceleration_discontinuity",
                                  jerk=f"{_JMG}acceleration_discontinuity")
CARTESIAN_POSE_NAMES = ErrorNames(velocity=f"{_CMG}velocity_limits_violation",
                                  acceleration=f"{_CMG}velocity_discontinuity",
                                  jerk=f"{_CMG}acceleration_discontinuity")
CARTESIAN_VELOCITY_NAMES = ErrorNames(velocity=f"{_CMG}velocity_limits_violation",
                                      acceleration=f"{_CMG}acceleration_discontinuity",
                                      jerk=f"{_CMG}acceleration_discontinuity")
ELBOW_NAMES = ErrorNames(*[f"{_CMG}elbow_limit_violation"] * 3)
JOINT_RANGE_ERROR = f"{_JMG}position_limits_violation"
JOINT_START_ERROR = "joint_position_motion_generator_start_pose_invalid"
CARTESIAN_START_ERROR = "cartesian_position_motion_generator_start_pose_invalid"
INVALID_FRAME_ERROR = "cartesian_position_motion_generator_invalid_frame"
ELBOW_START_ERROR = f"{_CMG}start_elbow_invalid"
ELBOW_START_SIGN_ERROR = "start_elbow_sign_inconsistent"
ELBOW_SIGN_ERROR = f"{_CMG}elbow_sign_inconsistent"
TORQUE_RATE_ERROR = "controller_torque_discontinuity"
# The FCI lists τ max as only *recommended* under torque control (docs/figures.md, "Joint and
# Cartesian limits"), so this is reported without aborting; tau_J_range_violation is the one
# error bit about joint-torque range.
TORQUE_RANGE_ERROR = "tau_J_range_violation"
MEASURED_VELOCITY_ERROR = "joint_velocity_violation"  # the safety controller, on measured dq
MEASURED_RANGE_ERROR = "joint_position_limits_violation"
# The joint side of a Cartesian motion (ik_joint_side.py), named after the generator.
IK_JOINT_NAMES = ErrorNames(velocity=f"{_CMG}joint_velocity_limits_violation",
                            acceleration=f"{_CMG}joint_velocity_discontinuity",
                            jerk=f"{_CMG}joint_acceleration_discontinuity")
IK_JOINT_RANGE_ERROR = f"{_CMG}joint_position_limits_violation"

# Every error the command-stream and measured checks can report: the bits an integrator may
# have to latch.
RAISED_ERRORS = tuple(sorted({
    *(name for names in (JOINT_POSITION_NAMES, JOINT_VELOCITY_NAMES, CARTESIAN_POSE_NAMES,
                         CARTESIAN_VELOCITY_NAMES, ELBOW_NAMES)
      for name in (names.velocity, names.acceleration, names.jerk)),
    JOINT_RANGE_ERROR, JOINT_START_ERROR, CARTESIAN_START_ERROR, INVALID_FRAME_ERROR,
    ELBOW_START_ERROR, ELBOW_START_SIGN_ERROR, ELBOW_SIGN_ERROR, TORQUE_RATE_ERROR,
    TORQUE_RANGE_ERROR, MEASURED_VELOCITY_ERROR, MEASURED_RANGE_ERROR,
}))
for _name in (*RAISED_ERRORS, *vars(IK_JOINT_NAMES).values(), IK_JOINT_RANGE_ERROR):
    error_index(_name)  # a misspelt name fails at import, not as a bit that never sets

# -- tolerances ---------------------------------------------------------------------------------
# Float32 echo. libfranka's limiter and filter anchor each new command on the *state's* copy of
# the previous one (q_d, dq_d, O_T_EE_c, tau_J_d, ...), which travels as float32, while the
# robot differences the double it received. The rounding (up to half an ulp) is thus injected
# into the stream once per cycle and amplified by 1/Δt per difference: for a joint angle below
# 8 rad that is 2.4e-7 rad → 0.24 rad/s² and 240 rad/s³ (≈5 % of the jerk limit). Without this
# slack a stream libfranka's own limiter produced at its jerk bound could be flagged. The slack
# is applied per number of differences between the echoed signal and the judged quantity.
# Magnitude bounds per signal (what the half-ulp is taken at):
JOINT_POSITION_MAGNITUDE = 8.0  # rad (joint 6 reaches 4.52)
JOINT_VELOCITY_MAGNITUDE = 8.0  # rad/s (joints 5 and 7: 5.26)
CARTESIAN_POSITION_MAGNITUDE = 2.0  # m (FR3 reach ≈ 0.86 m) and rotation-matrix entries (≤ 1)
TWIST_MAGNITUDE = 4.0  # m/s and rad/s
ELBOW_MAGNITUDE = 4.0  # rad (joint 3 spans ±2.91)
TORQUE_MAGNITUDE = 128.0  # Nm (effort 87)


def float32_half_ulp(magnitude: float) -> float:
    """Worst rounding error of a float32 copy of any number below `magnitude`."""
    below = np.nextafter(np.float32(magnitude), np.float32(0))
    return float(np.spacing(below)) / 2


def echo_slack(magnitude: float, differences: int) -> float:
    """How far `differences` backward differences can overshoot from float32-echo rounding."""
    return float32_half_ulp(magnitude) / CYCLE_PERIOD**differences


def derivative_thresholds(envelope: Envelope, magnitude: float, order: int) -> tuple[float, ...]:
    """Velocity, acceleration, jerk thresholds of a signal that is the `order`-th derivative
    (0: a position, 1: a velocity) echoed below `magnitude`: the limit plus the echo slack."""
    return tuple(limit + echo_slack(magnitude, k - order) for k, limit in
                 ((1, envelope.velocity), (2, envelope.acceleration), (3, envelope.jerk)))


# Start poses. The first command must be the pose the robot is in; a larger offset is a
# different pose, reported as *_start_pose_invalid. Smaller offsets are not waved through: the
# history starts at rest at the start pose, so anything above a few µrad already trips the
# ordinary discontinuity checks on the first cycle.
JOINT_START_TOLERANCE = 1e-3  # rad, per joint
CARTESIAN_START_TRANSLATION_TOLERANCE = 1e-3  # m
CARTESIAN_START_ROTATION_TOLERANCE = 1e-3  # rad
ELBOW_START_TOLERANCE = 1e-3  # rad

# A commanded pose is a frame if its last row is (0, 0, 0, 1) and its rotation part has RᵀR = I
# and det R = +1, each within this. libfranka already refuses to send rows/columns whose norm is
# off by more than 1e-5, so anything it lets through passes; float32 echo noise is ~1e-7.
FRAME_TOLERANCE = 1e-4

# The safety controller watches *measured* velocity, which is noisy (~1e-2 rad/s at rest on the
# robot: docs/figures.md, "Collision and estimator settings"). Near a range end the
# position-based law allows 0 rad/s toward it, so a threshold without slack would fire on noise
# of an arm simply held there. The slack also covers the joint controller's overshoot of a
# ramping velocity command (≈ 0.012 rad/s at 8 rad/s²), so a command that is too fast is named
# as such first, and the safety controller's joint_velocity_violation follows it, as on hardware
# (both are latched).
MEASURED_VELOCITY_TOLERANCE = 5e-2  # rad/s
