"""Everything the robot checks while one motion runs.

The guard composes the command-stream checker (commands.py), the joint side of Cartesian
commands (ik_joint_side.py) and the safety controller on the measured arm. It never decides to
abort: the limit policy does (policy.py).
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.robot.checks.commands import command_checker_for
from franka_sim.robot.checks.ik_joint_side import IkJointSideChecker
from franka_sim.robot.checks.joint_commands import AsyncTargetChecker
from franka_sim.robot.checks.safety_controller import MeasuredChecker
from franka_sim.robot.checks.violation import Violation
from franka_sim.robot.motion import CARTESIAN_GENERATORS, JointReference, MoveSpec


class MotionGuard:
    def __init__(self, desc: ArmDescription, spec: MoveSpec, *, q_start, O_T_EE_start,
                 elbow_start, joint_discontinuity_scale: float = 1.0) -> None:
        self.desc = desc
        self._measured = MeasuredChecker(desc)
        # An async motion's q_c is a goal for the robot's own generator, not a stream to judge.
        self._commands = AsyncTargetChecker(desc) if spec.use_async else command_checker_for(
            desc, spec.generator, spec.torque_controlled,
            q_start=q_start, O_T_EE_start=O_T_EE_start, elbow_start=elbow_start)
        self._ik = (IkJointSideChecker(desc, joint_discontinuity_scale)
                    if spec.generator in CARTESIAN_GENERATORS else None)
        self._cycles_since_applied = 0

    def released(self) -> None:
        """One more cycle went by (applied or not): the differencing interval grows."""
        self._cycles_since_applied += 1

    def judge_command(self, command, q_d, braked: bool = False) -> list[Violation]:
        """`q_d`: the robot's joint reference as the command arrives (what a gap carried on);
        `braked`: the gap was long enough that the robot braked the arm and held it."""
        cycles, self._cycles_since_applied = max(self._cycles_since_applied, 1), 0
        if braked and self._ik is not None:
            self._ik.resume()
        if cycles > 1:
            self._commands.resume(q_d)
        return self._commands.check(command, cycles)

    def judge_ik(self, reference: JointReference) -> list[Violation]:
        return [] if self._ik is None else self._ik.check(reference)

    def judge_measured(self, q: np.ndarray, dq: np.ndarray) -> list[Violation]:
        return self._measured.check(q, dq)
