"""Moves the end effector forth and back along a diagonal with a smooth Cartesian velocity.

A port of libfranka's generate_cartesian_velocity_motion example to pylibfranka's
active-control API. python generate_cartesian_velocity_motion.py HOST
"""

import math
import sys

import numpy as np
import pylibfranka

TIME_MAX = 4.0
V_MAX = 0.1
ANGLE = math.pi / 4.0


def main(host: str) -> np.ndarray:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    control = robot.start_cartesian_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    start = np.array(state.O_T_EE[12:15])
    time = 0.0
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        cycle = math.floor(math.pow(-1.0, (time - math.fmod(time, TIME_MAX)) / TIME_MAX))
        v = cycle * V_MAX / 2.0 * (1.0 - math.cos(2.0 * math.pi / TIME_MAX * time))
        command = pylibfranka.CartesianVelocities(
            [math.cos(ANGLE) * v, 0.0, -math.sin(ANGLE) * v, 0.0, 0.0, 0.0])
        if time >= 2 * TIME_MAX:
            command = pylibfranka.CartesianVelocities([0.0] * 6)
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    offset = np.array(robot.read_once().O_T_EE[12:15]) - start
    print("Finished motion, EE offset from start (m):", np.round(offset, 5).tolist())
    return offset


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
