"""Whether a Move may start, and the motion it starts.

The robot refuses a Move while another runs or while it is not Idle (a reflex must be recovered
first), and refuses a Cartesian generator at a singular pose, where its IK could not follow.
An admitted Move starts from the measured arm.
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.kinematics import flange_pose, tip_jacobian
from franka_sim.description.urdf import ArmDescription
from franka_sim.protocol.enums import MoveStatus, RobotMode
from franka_sim.robot.cartesian import SINGULAR_POSE_MIN_SINGULAR_VALUE, smallest_singular_value
from franka_sim.robot.checks.figures import motion_figures
from franka_sim.robot.checks.joint_table import joint_limits
from franka_sim.robot.motion import CARTESIAN_GENERATORS, Motion, MoveRejected, parse_move


def admit_move(desc: ArmDescription, command_id: int, request, *, running: bool,
               robot_mode: RobotMode, q: np.ndarray, O_T_F: np.ndarray | None,
               F_T_EE: np.ndarray) -> Motion:
    """The Motion a Move starts; raises MoveRejected with the robot's status if it may not."""
    spec = parse_move(request)
    if running:
        raise MoveRejected(MoveStatus.kCommandNotPossibleRejected, "a motion is already running")
    if robot_mode is RobotMode.kOther:
        raise MoveRejected(MoveStatus.kCommandNotPossibleRejected,
                           "robot is in kOther: brakes locked or not in Execution (Desk)")
    if robot_mode is not RobotMode.kIdle:
        raise MoveRejected(MoveStatus.kCommandNotPossibleRejected,
                           f"robot is in {robot_mode.name}; recover first")
    if spec.generator in CARTESIAN_GENERATORS:
        _check_not_singular(desc, q, F_T_EE)
    O_T_EE = (O_T_F if O_T_F is not None else flange_pose(desc, q)) @ F_T_EE
    return Motion(command_id, spec, q, O_T_EE, F_T_EE, figures=motion_figures(desc),
                  joint_velocity=desc.limit_array("velocity"), limits=joint_limits(desc))


def _check_not_singular(desc: ArmDescription, q: np.ndarray, F_T_EE: np.ndarray) -> None:
    sigma = smallest_singular_value(tip_jacobian(desc, q, F_T_EE))
    if sigma < SINGULAR_POSE_MIN_SINGULAR_VALUE:
        raise MoveRejected(
            MoveStatus.kStartAtSingularPoseRejected,
            f"EE Jacobian's smallest singular value {sigma:.4f} < "
            f"{SINGULAR_POSE_MIN_SINGULAR_VALUE}: cannot start at a singular pose",
        )
