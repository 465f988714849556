"""A mobile base's client program, as a user writes one: a pylibfranka Cartesian-velocity motion.

    python tests/mobile/base_program.py HOST VX VY WZ SECONDS

drives the base at the body twist (VX, VY, WZ) (m/s, rad/s), reached and left along cosine
ramps of RAMP, for SECONDS in all, then prints "started"-free JSON: the base's pose before and
after (x, y, yaw from O_T_EE), the pose the commanded twist integrates to, the largest steering
angles seen, the smallest success rate, and the error a ControlException reported.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pylibfranka

RAMP = 0.5  # s (within the base's acceleration limits for the twists the tests use)


def planar(state) -> tuple[float, float, float]:
    T = np.reshape(state.O_T_EE, (4, 4), order="F")
    return float(T[0, 3]), float(T[1, 3]), float(math.atan2(T[1, 0], T[0, 0]))


def profile(t: float, seconds: float) -> float:
    up = 0.5 * (1 - math.cos(math.pi * min(t / RAMP, 1.0)))
    down = 0.5 * (1 - math.cos(math.pi * min(max(seconds - t, 0.0) / RAMP, 1.0)))
    return min(up, down)


def run(host: str, twist, seconds: float) -> dict:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    before = planar(robot.read_once())
    control = robot.start_cartesian_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    x, y, yaw = before
    t, rates, steer, error, k = 0.0, [], [0.0, 0.0], "", 0
    vx = vy = wz = 0.0
    try:
        while True:
            state, period = control.readOnce()
            dt = period.to_sec()
            t += dt
            # What the base should have done: the body twist last commanded, integrated in the
            # start frame over the time until this state (more than 1 ms when a state was lost:
            # the robot went on with that command meanwhile).
            heading = yaw + 0.5 * wz * dt
            x += (math.cos(heading) * vx - math.sin(heading) * vy) * dt
            y += (math.sin(heading) * vx + math.cos(heading) * vy) * dt
            yaw += wz * dt
            k += 1
            if k > 3:
                rates.append(state.control_command_success_rate)
            for i in (0, 1):
                if abs(state.q[2 * i]) > abs(steer[i]):
                    steer[i] = state.q[2 * i]
            s = profile(t, seconds)
            vx, vy, wz = (s * v for v in twist)
            command = pylibfranka.CartesianVelocities([vx, vy, 0.0, 0.0, 0.0, wz])
            command.motion_finished = t >= seconds
            control.writeOnce(command)
            if command.motion_finished:
                break
    except pylibfranka.ControlException as exc:
        error = str(exc)
    final = robot.read_once()
    return {"before": before, "after": planar(final), "integrated": [x, y, yaw],
            "steer": steer, "q": list(final.q), "min_rate": min(rates, default=0.0),
            "error": error, "mode": str(final.robot_mode)}


if __name__ == "__main__":
    vx, vy, wz, seconds = (float(v) for v in sys.argv[2:6])
    print(json.dumps(run(sys.argv[1], (vx, vy, wz), seconds)), flush=True)
