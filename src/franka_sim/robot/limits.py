"""The FR3's motion limits as data: what the robot holds a command stream and the arm to.

Two kinds of figure live here. The fixed ones (joint acceleration and jerk, torque rate, the
Cartesian translation/rotation/elbow envelopes) are the datasheet values (fr3_facts.md §1.3),
which are the *robot's* thresholds; libfranka's client-side rate limiter uses the same figures
minus 1e-3 (protocol_v10.md §7), so a stream it produced stays inside them. The per-joint ones
(position range, velocity, effort, and the offset/deceleration of the position-based velocity
law) are read from the URDF the simulator serves, because that is where libfranka reads them
too: client and robot then agree by construction, even for a user-supplied description.

`safety.py` does the judging; nothing here depends on a motion's state.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from franka_sim.description.urdf import ArmDescription

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
    return float(np.spacing(np.float32(magnitude))) / 2


def echo_slack(magnitude: float, differences: int) -> float:
    """How far `differences` backward differences can overshoot from float32-echo rounding."""
    return float32_half_ulp(magnitude) / DT**differences


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
# threshold without slack would fire on noise of an arm simply held there.
MEASURED_VELOCITY_TOLERANCE = 1e-2  # rad/s


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
        # Stacked (2, 7) forms let the hot path evaluate both directions in one pass of ufuncs:
        # row 0 is "toward upper", row 1 is "toward lower" with the sign flipped.
        set_ = object.__setattr__
        set_(self, "_ends", np.stack([self.upper, self.lower]))
        set_(self, "_two_dec", 2.0 * self.deceleration)
        set_(self, "middle", (self.upper + self.lower) / 2)
        set_(self, "half_range", (self.upper - self.lower) / 2)

    def speed_bounds(self, q: np.ndarray) -> np.ndarray:
        """(2, 7): the allowed speed toward the upper (row 0) and lower (row 1) end, at q.

        The law (fr3_facts §1.4): the speed toward an end may not exceed what the joint can
        still brake from at its deceleration limit, less an offset, capped at the URDF velocity.
        Both rows are ≥ 0; the velocity range at q is [−row 1, row 0].
        """
        gap = (self._ends - q) * TOWARD  # distance left to each end (negative once past it)
        room = np.sqrt(np.maximum(gap, 0.0) * self._two_dec) - self.velocity_offset
        return np.minimum(np.maximum(room, 0.0), self.velocity)

    def velocity_range(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) velocity limits at q, in libfranka's signed form (without its 1e-3)."""
        bounds = self.speed_bounds(np.asarray(q, dtype=float))
        return -bounds[1], bounds[0]


# Row signs of the stacked (2, 7) forms: +1 toward the upper end, −1 toward the lower end.
TOWARD = np.array([[1.0], [-1.0]])


@lru_cache(maxsize=8)
def joint_limits(desc: ArmDescription) -> JointLimitTable:
    """The table of a description (cached: an ArmDescription is immutable and hashes by identity)."""
    return JointLimitTable.from_description(desc)
