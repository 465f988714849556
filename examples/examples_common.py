"""What libfranka's examples share: the behaviour they set before they move."""

from __future__ import annotations

import pylibfranka


def set_default_behavior(robot: pylibfranka.Robot) -> None:
    """Collision thresholds of 20 N / 20 Nm and the robot's usual joint and Cartesian impedance."""
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    robot.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 2000])
    robot.set_cartesian_impedance([3000, 3000, 3000, 300, 300, 300])
