"""Moves the end effector along a quarter circle in the x-z plane and back (Cartesian pose).

A port of libfranka's generate_cartesian_pose_motion example to pylibfranka's active-control
API. python generate_cartesian_pose_motion.py HOST [SECONDS]
"""

import math
import sys

import numpy as np
import pylibfranka

RADIUS = 0.3


def main(host: str, seconds: float = 10.0) -> float:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    control = robot.start_cartesian_pose_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    start = np.array(state.O_T_EE_c)
    time, worst = 0.0, 0.0
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        angle = math.pi / 4 * (1 - math.cos(math.pi / (seconds / 2) * time))
        pose = start.copy()
        pose[12] += RADIUS * math.sin(angle)
        pose[14] += RADIUS * (math.cos(angle) - 1)
        worst = max(worst, float(np.max(np.abs(np.array(state.O_T_EE[12:15]) - np.array(state.O_T_EE_c[12:15])))))
        command = pylibfranka.CartesianPose(pose.tolist())
        if time >= seconds:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    print(f"Finished motion, worst EE tracking error {worst * 1000:.3f} mm")
    return worst


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         float(sys.argv[2]) if len(sys.argv) > 2 else 10.0)
