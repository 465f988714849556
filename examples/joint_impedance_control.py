"""Torque control: a joint impedance written by the client, with Model.coriolis compensation.

The robot adds gravity compensation itself; the client adds coriolis, as libfranka's
joint_impedance_control example does. The set-point traces a small circle in joints 1 and 4
(pylibfranka has no torque-plus-Cartesian-reference API, so the trajectory lives here).
python joint_impedance_control.py HOST [SECONDS]
"""

import math
import sys

import numpy as np
import pylibfranka

K = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])
D = np.array([50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0])
RADIUS = 0.1  # rad
PERIOD = 2.0  # s


def main(host: str, seconds: float = 4.0) -> float:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    model = robot.load_model()
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    q0 = np.array(state.q)
    time, worst = 0.0, 0.0
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        angle = 2 * math.pi * time / PERIOD
        ramp = min(1.0, time)  # start at the current pose, then grow the circle
        q_d = q0.copy()
        q_d[0] += ramp * RADIUS * math.sin(angle)
        q_d[3] += ramp * RADIUS * (1 - math.cos(angle))
        q = np.array(state.q)
        worst = max(worst, float(np.max(np.abs(q_d - q))))
        tau = K * (q_d - q) - D * np.array(state.dq) + np.array(model.coriolis(state))
        command = pylibfranka.Torques(tau.tolist())
        if time >= seconds:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    print(f"max joint tracking error {worst:.4f} rad")
    return worst


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         float(sys.argv[2]) if len(sys.argv) > 2 else 4.0)
