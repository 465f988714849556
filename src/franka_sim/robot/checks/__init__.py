"""Motion-limit checks: judge a motion's command stream, and the measured arm, as the robot does.

figures (the fixed limits, error names, tolerances), joint_table (the URDF's per-joint limits
and the velocity law), measuring (sample grid, frames, rotations); one checker per command
interface behind `CommandChecker` (joint_commands, cartesian_commands, elbow_command,
torque_command), picked per Move by `command_checker_for`; ik_joint_side (the IK's joint
motion), safety_controller (the measured arm); `MotionGuard` composes them for one motion and
`LimitPolicy` decides whether a violation aborts it or is only logged.
"""

from franka_sim.robot.checks import figures, joint_table, measuring
from franka_sim.robot.checks.checker import CommandChecker
from franka_sim.robot.checks.commands import command_checker_for
from franka_sim.robot.checks.figures import RAISED_ERRORS
from franka_sim.robot.checks.guard import MotionGuard
from franka_sim.robot.checks.ik_joint_side import IkJointSideChecker
from franka_sim.robot.checks.policy import LimitPolicy
from franka_sim.robot.checks.safety_controller import MeasuredChecker, check_measured
from franka_sim.robot.checks.violation import Violation, ViolationLog, error_names

__all__ = [
    "CommandChecker", "IkJointSideChecker", "LimitPolicy", "MeasuredChecker", "MotionGuard",
    "RAISED_ERRORS", "Violation", "ViolationLog", "check_measured", "command_checker_for",
    "error_names", "figures", "joint_table", "measuring",
]
