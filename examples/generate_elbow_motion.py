"""Swings the elbow (joint 3) while the end effector stays put, as libfranka's
generate_elbow_motion example does.

pylibfranka's CartesianPose carries no elbow, so this example uses franky (libfranka underneath,
its own trajectory generation): a Cartesian motion to the current pose with a new elbow angle.
python generate_elbow_motion.py HOST [DELTA_RAD]
"""

import sys

import numpy as np
from franky import (
    Affine, CartesianMotion, ElbowState, RealtimeConfig, RelativeDynamicsFactor, Robot, RobotPose,
)


def main(host: str, delta: float = 0.3) -> tuple[float, float]:
    robot = Robot(host, realtime_config=RealtimeConfig.Ignore)
    robot.relative_dynamics_factor = RelativeDynamicsFactor(0.2, 0.2, 0.2)
    start = robot.current_cartesian_state.pose.end_effector_pose
    q3 = float(robot.current_joint_state.position[2])
    for target in (q3 + delta, q3):
        robot.move(CartesianMotion(RobotPose(Affine(start.matrix), ElbowState(target))))
        state = robot.current_joint_state
        moved = np.linalg.norm(robot.current_cartesian_state.pose.end_effector_pose.translation
                               - start.translation)
        print(f"elbow q3 = {state.position[2]:.4f} (target {target:.4f}); "
              f"EE moved {moved * 1000:.3f} mm")
    return float(state.position[2]), float(moved)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         float(sys.argv[2]) if len(sys.argv) > 2 else 0.3)
