"""Everything the robot checks while one motion runs, and how a violation is reported.

The guard composes the command-stream checker (safety.MotionLimitChecker), the joint side of
Cartesian commands (ik_limits) and the safety controller on the measured arm. It never decides
to abort: the core does, when `--enforce-motion-limits` is on. Checking and logging are always
on; the log is rate-limited per error name so a violating client cannot flood it.
"""

from __future__ import annotations

import logging

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.robot.ik_limits import IkJointSideChecker
from franka_sim.robot.motion import CARTESIAN_GENERATORS, MoveSpec, JointReference
from franka_sim.robot.safety import MeasuredChecker, MotionLimitChecker, Violation

log = logging.getLogger(__name__)

# A commanded velocity over its limit makes the safety controller trip as well (hardware is
# reported to latch both names).
COMPANION_ERRORS = {"joint_motion_generator_velocity_limits_violation": "joint_velocity_violation"}


class MotionGuard:
    def __init__(self, desc: ArmDescription, spec: MoveSpec, *, q_start, O_T_EE_start,
                 elbow_start, joint_discontinuity_scale: float = 1.0) -> None:
        self.desc = desc
        self._measured = MeasuredChecker(desc)
        # An async motion's q_c is a goal for the robot's own generator, not a stream to judge.
        self._commands = None if spec.use_async else MotionLimitChecker(
            desc, spec.generator, spec.torque_controlled,
            q_start=q_start, O_T_EE_start=O_T_EE_start, elbow_start=elbow_start)
        self._ik = (IkJointSideChecker(desc, joint_discontinuity_scale)
                    if spec.generator in CARTESIAN_GENERATORS else None)
        self._cycles_since_applied = 0

    def released(self) -> None:
        """One more cycle went by (applied or not): the differencing interval grows."""
        self._cycles_since_applied += 1

    def judge_command(self, command) -> list[Violation]:
        cycles, self._cycles_since_applied = max(self._cycles_since_applied, 1), 0
        return [] if self._commands is None else self._commands.check(command, cycles)

    def judge_ik(self, reference: JointReference) -> list[Violation]:
        return [] if self._ik is None else self._ik.check(reference)

    def judge_measured(self, q: np.ndarray, dq: np.ndarray) -> list[Violation]:
        return self._measured.check(q, dq)


def error_names(violations: list[Violation]) -> list[str]:
    """The error bits an aborting set of violations latches (companions included)."""
    names = {v.name for v in violations if v.aborts}
    names |= {COMPANION_ERRORS[n] for n in names if n in COMPANION_ERRORS}
    return sorted(names)


class ViolationLog:
    """One warning line per violation, thinned out per error name (1st, 10th, 100th, every 1000th)."""

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}

    def report(self, violations: list[Violation], enforced: bool) -> None:
        for v in violations:
            n = self._counts.get(v.name, 0) + 1
            self._counts[v.name] = n
            if n in (1, 10, 100) or n % 1000 == 0:
                action = "aborting" if enforced and v.aborts else "not enforced"
                log.warning("%s (%s; %d so far)", v.describe(), action, n)
