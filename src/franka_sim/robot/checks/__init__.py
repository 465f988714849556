from franka_sim.robot.checks.policy import LimitPolicy
from franka_sim.robot.motion_guard import MotionGuard

__all__ = ["LimitPolicy", "MotionGuard"]
