"""A joint impedance controller: the code under test in this example project.

Torque control through pylibfranka: tau = K (q_d - q) - D dq + coriolis, where the set-point q_d
moves from where the arm is to the goal along a minimum-jerk path and then stays there. The robot
compensates gravity itself; the controller adds the Coriolis torques from the robot's model.
"""

from __future__ import annotations

import numpy as np
import pylibfranka

K = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])  # Nm/rad
D = np.array([50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0])  # Nm s/rad


def connect(host: str) -> pylibfranka.Robot:
    """The robot, with collision thresholds high enough for a person's push (40 N, 40 Nm)."""
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
    return robot


def minimum_jerk(s: float) -> float:
    """0 → 1 as s goes 0 → 1, with zero velocity and acceleration at both ends."""
    s = min(max(s, 0.0), 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def move_to(robot: pylibfranka.Robot, q_goal, duration: float = 0.8, hold: float = 0.2,
            every_cycle=None, model: pylibfranka.Model | None = None) -> pylibfranka.RobotState:
    """Move to q_goal in `duration` seconds, hold it for `hold` more; return the last state.

    `every_cycle(t, state)`, if given, runs once per cycle between reading the state and
    answering it (t: seconds since the motion began).
    """
    if model is None:
        model = robot.load_model()
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    q_start = np.array(state.q)
    delta = np.asarray(q_goal, float) - q_start
    t = 0.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        if every_cycle is not None:
            every_cycle(t, state)
        q_d = q_start + delta * minimum_jerk(t / duration)
        tau = K * (q_d - np.array(state.q)) - D * np.array(state.dq) + model.coriolis(state)
        command = pylibfranka.Torques(tau.tolist())
        command.motion_finished = t >= duration + hold
        control.writeOnce(command)
        if command.motion_finished:
            return state
