"""The joint side of Cartesian commands: the IK's joint motion is held to the joint limits.

A Cartesian stream well inside its own limits can still ask for violent joint motion (near a
singularity the IK amplifies it); the robot judges the completed joint signal and names those
errors cartesian_motion_generator_joint_*. Thresholds are the joint envelope times
`--joint-discontinuity-scale` (1.0: the FR3's 10 rad/s² and 5000 rad/s³, the Panda's per joint).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.robot.checks.figures import (
    IK_JOINT_NAMES, IK_JOINT_RANGE_ERROR, motion_figures,
)
from franka_sim.robot.checks.joint_table import SpeedLimitFloor, joint_limits
from franka_sim.robot.checks.violation import Violation

if TYPE_CHECKING:
    from franka_sim.robot.motion import JointReference


# The first command after a braked gap differences the client's stream over the gap, the next
# steps the IK from rest to the client's speed (acceleration), and the one after ends that
# step (jerk).
RESTART_CYCLES = 3


class IkJointSideChecker:
    """One Cartesian motion's IK output against the (scaled) joint limits; a fresh one per Move."""

    def __init__(self, desc: ArmDescription, scale: float = 1.0) -> None:
        self._table = joint_limits(desc)
        figures = motion_figures(desc)
        self._acceleration = figures.joint_acceleration * scale  # (7,)
        self._jerk = figures.joint_jerk * scale
        self._ddq_prev = np.zeros(7)
        self._floor: SpeedLimitFloor | None = None
        self._proof_thresholds = None
        self._restarting = 0  # cycles left in which the IK restarts from a held arm

    def resume(self) -> None:
        """The client is heard again after the robot braked its arm and held it: the IK's
        joint motion starts again from rest, at the client's speed. That step is the gap's,
        not the client's (its Cartesian stream is judged across the gap, as a joint stream
        is), so for the cycles its acceleration and jerk take to show it only the range and
        the velocity law are judged."""
        self._restarting = RESTART_CYCLES

    def check(self, ref: JointReference) -> list[Violation]:
        """Judge this cycle's IK output (q_d, dq_d, ddq_d of the Cartesian motion)."""
        jerk = (ref.ddq_d - self._ddq_prev) / CYCLE_PERIOD
        self._ddq_prev = ref.ddq_d.copy()
        if self._restarting:
            self._restarting -= 1
            self._floor = None
            return [v for v in self._violations(ref, jerk)
                    if v.quantity not in ("acceleration", "jerk")]
        # The usual case in one comparison: in range and within the floor's reach, under the
        # floor of the velocity law, and under the acceleration and jerk limits.
        signed = self._table.signed_stack(ref.q_d, ref.dq_d, ref.ddq_d, jerk)
        if self._floor is not None and all((signed <= self._proof_thresholds).tolist()):
            return []
        self._move_floor(signed[:14])
        return self._violations(ref, jerk)

    def _move_floor(self, q_signed: np.ndarray) -> None:
        floor = self._floor = SpeedLimitFloor(self._table, q_signed)
        self._proof_thresholds = np.concatenate((floor.reach_in_range, floor.limits,
                                                 np.tile(self._acceleration, 2),
                                                 np.tile(self._jerk, 2)))

    def _violations(self, ref: JointReference, jerk: np.ndarray) -> list[Violation]:
        table, out = self._table, []
        for i, limit in table.ends_passed(table.signed(ref.q_d)):
            out.append(Violation(IK_JOINT_RANGE_ERROR, f"joint {i + 1}",
                                 float(ref.q_d[i]), limit, quantity="position", unit="rad"))
        lower, upper = table.velocity_range(ref.q_d)
        for i in np.flatnonzero((ref.dq_d > upper) | (ref.dq_d < lower)):
            limit = float(upper[i] if ref.dq_d[i] > 0 else lower[i])
            out.append(Violation(IK_JOINT_NAMES.velocity, f"joint {i + 1}",
                                 float(ref.dq_d[i]), limit, quantity="velocity", unit="rad/s"))
        for i in np.flatnonzero(np.abs(ref.ddq_d) > self._acceleration):
            out.append(Violation(IK_JOINT_NAMES.acceleration, f"joint {i + 1}",
                                 float(abs(ref.ddq_d[i])), float(self._acceleration[i]),
                                 quantity="acceleration", unit="rad/s²"))
        for i in np.flatnonzero(np.abs(jerk) > self._jerk):
            out.append(Violation(IK_JOINT_NAMES.jerk, f"joint {i + 1}",
                                 float(abs(jerk[i])), float(self._jerk[i]), quantity="jerk",
                                 unit="rad/s³"))
        return out
