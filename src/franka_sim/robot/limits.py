"""The FR3's motion limits as data: what the robot holds a command stream and the arm to.

Two kinds of figure live here. The fixed ones (joint acceleration and jerk, torque rate, the
Cartesian translation/rotation/elbow envelopes) are the datasheet values (fr3_facts.md §1.3),
which are the *robot's* thresholds; libfranka's client-side rate limiter uses the same figures
minus 1e-3 (protocol_v10.md §7), so a stream it produced stays inside them. The per-joint ones
(position range, velocity, effort, and the offset/deceleration of the position-based velocity
law) are read from the URDF the simulator serves, because that is where libfranka reads them
too: client and robot then agree by construction, even for a user-supplied description.

Also here, the small measuring tools the checks share: what counts as a frame, the rotation
between two poses, the sample grid the derivatives are taken on, and a floor under the
velocity law that lets the usual in-limits cycle skip evaluating it. `safety.py` does the
judging; nothing here depends on a motion's state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.protocol.errors import error_index

DT = 1e-3  # s, one FCI cycle

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


# -- the error each limit latches (protocol_v10.md §3) ------------------------------------------
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
# The FCI lists τ max as only *recommended* under torque control (fr3_facts §1.3), so this is
# reported without aborting; tau_J_range_violation is the one error bit about joint-torque range.
TORQUE_RANGE_ERROR = "tau_J_range_violation"
MEASURED_VELOCITY_ERROR = "joint_velocity_violation"  # the safety controller, on measured dq
MEASURED_RANGE_ERROR = "joint_position_limits_violation"

# Every error the checks can report: the bits an integrator may have to latch.
RAISED_ERRORS = tuple(sorted({
    *(name for names in (JOINT_POSITION_NAMES, JOINT_VELOCITY_NAMES, CARTESIAN_POSE_NAMES,
                         CARTESIAN_VELOCITY_NAMES, ELBOW_NAMES)
      for name in (names.velocity, names.acceleration, names.jerk)),
    JOINT_RANGE_ERROR, JOINT_START_ERROR, CARTESIAN_START_ERROR, INVALID_FRAME_ERROR,
    ELBOW_START_ERROR, ELBOW_START_SIGN_ERROR, ELBOW_SIGN_ERROR, TORQUE_RATE_ERROR,
    TORQUE_RANGE_ERROR, MEASURED_VELOCITY_ERROR, MEASURED_RANGE_ERROR,
}))
for _name in RAISED_ERRORS:
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
    return float32_half_ulp(magnitude) / DT**differences


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
# robot, fr3_facts §4). Near a range end the position-based law allows 0 rad/s toward it, so a
# threshold without slack would fire on noise of an arm simply held there. The slack also covers
# the joint controller's overshoot of a ramping velocity command (≈ 0.012 rad/s at 8 rad/s²),
# so a command that is too fast is named as such first, and the safety controller's
# joint_velocity_violation follows it, as on hardware (both are latched).
MEASURED_VELOCITY_TOLERANCE = 5e-2  # rad/s


def frame_defect(m: list) -> tuple[float, float, str] | None:
    """None if 16 numbers (column-major 4×4) are a rigid transform, else (value, limit, quantity)
    saying why not: how far it is from one, or a rotation determinant of −1 (a mirror image)."""
    c0, c1, c2 = m[0:3], m[4:7], m[8:11]
    row = abs(m[3]) + abs(m[7]) + abs(m[11]) + abs(m[15] - 1.0)
    gram = max(abs(_dot(c0, c0) - 1.0), abs(_dot(c1, c1) - 1.0), abs(_dot(c2, c2) - 1.0),
               abs(_dot(c0, c1)), abs(_dot(c0, c2)), abs(_dot(c1, c2)))
    if not max(row, gram) <= FRAME_TOLERANCE:
        return max(row, gram), FRAME_TOLERANCE, "deviation from a rigid transform"
    det = _dot(c0, (c1[1] * c2[2] - c1[2] * c2[1], c1[2] * c2[0] - c1[0] * c2[2],
                    c1[0] * c2[1] - c1[1] * c2[0]))
    return None if det > 0.0 else (det, 1.0, "rotation determinant")


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def rotation_rows(m: list) -> tuple:
    """Rows of the rotation part of a 4×4 given as 16 numbers, column-major."""
    return (m[0], m[4], m[8]), (m[1], m[5], m[9]), (m[2], m[6], m[10])


def rotation_step(R0: tuple, R1: tuple) -> tuple[float, tuple[float, float, float]]:
    """Angle and base-frame unit axis of the rotation from R0 to R1 (rows), i.e. of R1·R0ᵀ.

    The angle is that of R0ᵀ·R1 too. It comes from the skew part and the trace via atan2, which
    keeps steps of a few µrad exact where acos of the trace would lose them to rounding.
    Plain floats: on 3-vectors they beat numpy's per-call overhead several times over.
    """
    wx = _dot(R1[2], R0[1]) - _dot(R1[1], R0[2])
    wy = _dot(R1[0], R0[2]) - _dot(R1[2], R0[0])
    wz = _dot(R1[1], R0[0]) - _dot(R1[0], R0[1])
    two_sin = math.sqrt(wx * wx + wy * wy + wz * wz)
    angle = math.atan2(two_sin, _dot(R1[0], R0[0]) + _dot(R1[1], R0[1]) + _dot(R1[2], R0[2]) - 1.0)
    if two_sin <= 1e-300:
        return angle, (0.0, 0.0, 0.0)
    return angle, (wx / two_sin, wy / two_sin, wz / two_sin)


class SampleGrid:
    """Where one signal's samples fell, in whole cycles; before the motion, 1 ms cycles at rest.

    A first difference over an interval belongs to its middle, so the next order divides by
    the distance between middles; on a uniform grid all three spacings are one cycle.
    """

    __slots__ = ("h1", "h0", "pending")

    def __init__(self) -> None:
        self.h1 = self.h0 = 1  # the last two intervals
        self.pending = 0  # cycles whose samples were skipped (not commanded, or invalid)

    def spacings(self, n: int) -> tuple[float, float, float]:
        """Seconds between the samples of the 0th, 1st and 2nd differences that end now."""
        return n * DT, (n + self.h1) * (DT / 2), (n + 2 * self.h1 + self.h0) * (DT / 4)

    def advance(self, n: int) -> None:
        self.h0, self.h1, self.pending = self.h1, n, 0


@dataclass(frozen=True, eq=False)
class JointLimitTable:
    """Per-joint figures of the served URDF, as (7,) arrays, plus the velocity law over them."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    velocity_offset: np.ndarray
    deceleration: np.ndarray

    @classmethod
    def from_description(cls, desc: ArmDescription) -> "JointLimitTable":
        return cls(
            lower=desc.limit_array("lower"), upper=desc.limit_array("upper"),
            velocity=desc.limit_array("velocity"), effort=desc.limit_array("effort"),
            velocity_offset=desc.limit_array("velocity_offset"),
            deceleration=desc.limit_array("deceleration_limit"),
        )

    def __post_init__(self) -> None:
        # The hot path works on "signed" 14-vectors, x → [x, −x]: entry i looks toward joint i's
        # upper end, entry 7+i toward its lower end, so one pass of ufuncs judges both directions
        # without abs() or broadcasting (each numpy call costs ~0.3 µs whatever the size).
        set_ = object.__setattr__
        set_(self, "ends", np.concatenate([self.upper, -self.lower]))  # [u, −l]
        set_(self, "_two_dec", np.tile(2.0 * self.deceleration, 2))
        set_(self, "_offset", np.tile(self.velocity_offset, 2))
        set_(self, "_cap", np.tile(self.velocity, 2))

    @staticmethod
    def signed(x) -> np.ndarray:
        """[x, −x] for a (7,) vector: the form `ends` and `speed_limits` use."""
        return np.asarray(x, dtype=float)[_TWICE] * _SIGNS

    @staticmethod
    def signed_stack(*vectors) -> np.ndarray:
        """signed() of a few (7,) vectors, one after the other, in one pass."""
        n = len(vectors)
        return np.concatenate(vectors)[_TWICE_STACKED[n]] * _SIGNS_STACKED[n]

    def speed_limits(self, q_signed: np.ndarray) -> np.ndarray:
        """(14,) speed allowed toward each end (upper ends first) at `signed(q)`; all ≥ 0.

        The law (fr3_facts §1.4): no faster toward an end than the joint can still brake from at
        its deceleration limit, less an offset, and never over the URDF velocity. The velocity
        range at q is [−limits[7:], limits[:7]].
        """
        gap = self.ends - q_signed  # distance left to each end (negative once past it)
        room = np.sqrt(np.maximum(gap, 0.0) * self._two_dec) - self._offset
        return np.minimum(np.maximum(room, 0.0), self._cap)

    def ends_passed(self, q_signed: np.ndarray) -> list[tuple[int, float]]:
        """(joint index, the URDF limit) for each range end `signed(q)` lies beyond."""
        passed = np.flatnonzero(~(q_signed <= self.ends))
        return [(e % 7, float(self.upper[e] if e < 7 else self.lower[e - 7])) for e in passed]

    def velocity_range(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) velocity limits at q, in libfranka's signed form (without its 1e-3)."""
        limits = self.speed_limits(self.signed(q))
        return -limits[7:], limits[:7]


_TWICE = np.r_[0:7, 0:7]
_SIGNS = np.r_[np.ones(7), -np.ones(7)]
_TWICE_STACKED = {n: np.concatenate([_TWICE + 7 * k for k in range(n)]) for n in range(1, 5)}
_SIGNS_STACKED = {n: np.tile(_SIGNS, n) for n in range(1, 5)}


class SpeedLimitFloor:
    """Speed limits that hold from below near a pose, so that a check can skip the velocity law.

    `speed_limits` only grows with the distance to each end, and so does each of its rounded
    steps: the limits at a signed pose `reach` are a floor under those at every signed q ≤
    reach. Laid MARGIN rad ahead of a pose toward every end, the floor proves a stream inside
    the law with one comparison for as long as it stays within reach; the checks evaluate the
    law itself only when that proof fails (near an end, too fast, or out of reach), and then
    move the floor to where the arm is.
    """

    MARGIN = 0.05  # rad: left behind after 10–20 cycles at the FR3's top joint speeds

    def __init__(self, table: JointLimitTable, q_signed: np.ndarray) -> None:
        self.reach = q_signed + self.MARGIN
        self.limits = table.speed_limits(self.reach)
        self.reach_in_range = np.minimum(self.reach, table.ends)


@lru_cache(maxsize=8)
def joint_limits(desc: ArmDescription) -> JointLimitTable:
    """The table of a description (cached: an ArmDescription is immutable, hashed by identity)."""
    return JointLimitTable.from_description(desc)
