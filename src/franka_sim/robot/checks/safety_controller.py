"""The safety controller: the *measured* arm against the URDF range and velocity law, in every
mode (the command checks judge what the client asked for; this judges what the arm does)."""

from __future__ import annotations

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.kernels import measured_inside
from franka_sim.robot.checks.figures import (
    MEASURED_RANGE_ERROR, MEASURED_VELOCITY_ERROR, MEASURED_VELOCITY_TOLERANCE,
)
from franka_sim.robot.checks.joint_table import JointLimitTable, SpeedLimitFloor, joint_limits
from franka_sim.robot.checks.violation import Violation


def check_measured(desc: ArmDescription, q, dq) -> list[Violation]:
    """The measured q and dq against the range and the velocity law.

    Measured velocity gets MEASURED_VELOCITY_TOLERANCE of slack (sensor noise; see figures.py).
    """
    table = joint_limits(desc)
    return _measured_violations(table, table.signed(q), table.signed(dq))


class MeasuredChecker:
    """check_measured for one motion, cycle after cycle: the law is evaluated only when a
    SpeedLimitFloor near the arm cannot prove it inside (the verdict is the same)."""

    def __init__(self, desc: ArmDescription) -> None:
        self._table = joint_limits(desc)
        self._proof: tuple | None = None  # (offsets, thresholds) of the floor, see check

    def check(self, q, dq) -> list[Violation]:
        table, proof = self._table, self._proof
        # In range and within the floor's reach (q − 0 ≤ reach), and no faster than the floor
        # allows (dq − floor ≤ tolerance): nothing to report.
        if proof is not None and measured_inside(q, dq, *proof):
            return []
        q, dq = table.signed(q), table.signed(dq)
        floor = SpeedLimitFloor(table, q)
        self._proof = (np.concatenate((np.zeros(14), floor.limits)),
                       np.concatenate((floor.reach_in_range,
                                       np.full(14, MEASURED_VELOCITY_TOLERANCE))))
        return _measured_violations(table, q, dq)


def _measured_violations(table: JointLimitTable, q: np.ndarray,
                         dq: np.ndarray) -> list[Violation]:
    """check_measured on signed q and dq."""
    tolerance = MEASURED_VELOCITY_TOLERANCE
    excess = q - table.ends
    moving = max(dq.tolist()) > tolerance  # slower never trips: the law is never below 0
    if moving:
        limits = table.speed_limits(q)
        excess = np.maximum(excess, dq - limits - tolerance)
    if max(excess.tolist()) <= 0.0:
        return []
    out = [Violation(MEASURED_RANGE_ERROR, f"joint {i + 1}", float(q[i]), limit,
                     quantity="measured position", unit="rad") for i, limit in table.ends_passed(q)]
    if moving:
        out.extend(Violation(MEASURED_VELOCITY_ERROR, f"joint {e % 7 + 1}", float(abs(dq[e])),
                             float(limits[e]), quantity="measured velocity", unit="rad/s")
                   for e in np.flatnonzero(~(dq <= limits + tolerance)))
    return out
