"""The per-joint limits of the served URDF, and the position-based velocity law over them.

Position range, velocity, effort, and the offset/deceleration of the velocity law are read from
the URDF the simulator serves, because that is where libfranka reads them too: client and robot
then agree by construction, even for a user-supplied description.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.kernels import signed


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

    # [x, −x] for a (7,) vector: the form `ends` and `speed_limits` use (the kernels' own).
    signed = staticmethod(signed)

    @staticmethod
    def signed_stack(*vectors) -> np.ndarray:
        """signed() of a few (7,) vectors, one after the other, in one pass."""
        n = len(vectors)
        return np.concatenate(vectors)[_TWICE_STACKED[n]] * _SIGNS_STACKED[n]

    def speed_limits(self, q_signed: np.ndarray) -> np.ndarray:
        """(14,) speed allowed toward each end (upper ends first) at `signed(q)`; all ≥ 0.

        The law (docs/figures.md, "The position-based velocity limit law"): no faster toward an
        end than the joint can still brake from at its deceleration limit, less an offset, and
        never over the URDF velocity. The velocity range at q is [−limits[7:], limits[:7]].
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
