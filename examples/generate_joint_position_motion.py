"""Moves joints 4, 5 and 7 with a smooth cosine joint-position profile, then stops.

A port of libfranka's generate_joint_position_motion example to pylibfranka's active-control
API. Run it against franka-sim or a real robot: python generate_joint_position_motion.py HOST
"""

import math
import sys

import pylibfranka


def main(host: str) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    robot.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 2000])
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q_start = list(state.q_d)
    excursion = [0.0] * 7  # the largest |q - q_start| each joint reached
    time = 0.0
    while True:
        state, period = control.readOnce()
        excursion = [max(e, abs(q - q0)) for e, q, q0 in zip(excursion, state.q, q_start)]
        time += period.to_sec()
        delta = math.pi / 8.0 * (1 - math.cos(math.pi / 2.5 * time))
        q = list(q_start)
        q[3] += delta
        q[4] += delta
        q[6] += delta
        command = pylibfranka.JointPositions(q)
        if time >= 5.0:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    print("Finished motion, q =", [round(v, 4) for v in robot.read_once().q])
    print("Largest excursion per joint =", [round(e, 4) for e in excursion])


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
