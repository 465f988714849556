"""Swings joints 4–7 back and forth with a smooth joint-velocity profile, then stops.

A port of libfranka's generate_joint_velocity_motion example to pylibfranka's active-control
API: python generate_joint_velocity_motion.py HOST
"""

import math
import sys

import pylibfranka

TIME_MAX = 1.0
OMEGA_MAX = 1.0


def main(host: str) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    robot.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 2000])
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    time = 0.0
    state, _ = control.readOnce()
    q_start = list(state.q)
    excursion = [0.0] * 7  # the largest |q - q_start| each joint reached
    while True:
        state, period = control.readOnce()
        excursion = [max(e, abs(q - q0)) for e, q, q0 in zip(excursion, state.q, q_start)]
        time += period.to_sec()
        cycle = math.floor(math.pow(-1.0, (time - math.fmod(time, TIME_MAX)) / TIME_MAX))
        omega = cycle * OMEGA_MAX / 2.0 * (1.0 - math.cos(2.0 * math.pi / TIME_MAX * time))
        command = pylibfranka.JointVelocities([0.0, 0.0, 0.0, omega, omega, omega, omega])
        if time >= 2 * TIME_MAX:
            command = pylibfranka.JointVelocities([0.0] * 7)
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    print("Finished motion, q =", [round(v, 4) for v in robot.read_once().q])
    print("Largest excursion per joint =", [round(e, 4) for e in excursion])


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
