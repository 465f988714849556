"""Which checkers judge a Move's command stream, picked once per Move.

Only the active generator's signal is judged (a joint motion carries a zero-filled O_T_EE_c
that is not even a frame), plus tau_J_d under the external controller.
"""

from __future__ import annotations

from franka_sim.description.urdf import ArmDescription
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.robot.checks.cartesian_commands import (
    CartesianPoseChecker, CartesianVelocityChecker,
)
from franka_sim.robot.checks.checker import CheckerChain, CommandChecker
from franka_sim.robot.checks.elbow_command import ElbowChecker
from franka_sim.robot.checks.figures import motion_figures
from franka_sim.robot.checks.joint_commands import JointPositionChecker, JointVelocityChecker
from franka_sim.robot.checks.joint_table import joint_limits
from franka_sim.robot.checks.torque_command import TorqueChecker


def command_checker_for(desc: ArmDescription, generator: Gen, torque_controlled: bool, *,
                        q_start=None, O_T_EE_start=None, elbow_start=None) -> CommandChecker:
    """The checker of one Move's stream (a fresh one per Move), for its generator and controller.

    q_start / O_T_EE_start (4×4, or 16 numbers column-major) / elbow_start are the start the
    robot holds (what the state showed as the motion began); only those the generator needs are
    required. A Cartesian generator's elbow is judged too, after its pose or twist.
    """
    generator = Gen(generator)
    figures = motion_figures(desc)
    table = joint_limits(desc)
    elbow_range = (float(table.lower[2]), float(table.upper[2]))
    checkers: list[CommandChecker] = []
    if generator is Gen.kJointPosition:
        checkers.append(JointPositionChecker(desc, q_start))
    elif generator is Gen.kJointVelocity:
        checkers.append(JointVelocityChecker(desc, q_start))
    elif generator is Gen.kCartesianPosition:
        checkers += (CartesianPoseChecker(O_T_EE_start, figures),
                     ElbowChecker(elbow_start, figures, elbow_range))
    elif generator is Gen.kCartesianVelocity:
        checkers += (CartesianVelocityChecker(figures),
                     ElbowChecker(elbow_start, figures, elbow_range))
    if torque_controlled:
        checkers.append(TorqueChecker(desc))
    return checkers[0] if len(checkers) == 1 else CheckerChain(*checkers)
