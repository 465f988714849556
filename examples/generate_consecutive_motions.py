"""Several joint-velocity motions back to back, recovering from any error in between.

A port of libfranka's generate_consecutive_motions example to pylibfranka's active-control
API. After a joint motion to the ready pose, each motion swings joint 3 out and back with a
smooth velocity profile (peak 0.2 rad/s, 8 s) under low collision thresholds, and the next
one starts as soon as the previous one finished, from wherever the arm then is. A motion that
fails is reported, the robot is recovered with automatic_error_recovery and the loop goes on.

    python generate_consecutive_motions.py HOST [MOTIONS]
"""

from __future__ import annotations

import math
import sys

import pylibfranka

import pick_and_place as pp  # its joint motion, for getting to the ready pose
from examples_common import set_default_behavior

MOTIONS = 5
TIME_MAX = 4.0  # s: half a motion
OMEGA_MAX = 0.2  # rad/s
# Low thresholds, per joint and per Cartesian axis, lower = upper: any real push is a reflex.
TORQUE_THRESHOLDS = [10.0, 10.0, 9.0, 9.0, 8.0, 7.0, 6.0]  # Nm
FORCE_THRESHOLDS = [10.0, 10.0, 10.0, 12.5, 12.5, 12.5]  # N, Nm


def omega(time: float) -> float:
    """Joint 3's velocity: a raised cosine forward over the first TIME_MAX, backward over the next."""
    direction = 1.0 if time < TIME_MAX else -1.0
    return direction * OMEGA_MAX / 2.0 * (1.0 - math.cos(2.0 * math.pi / TIME_MAX * time))


def swing(robot: pylibfranka.Robot) -> tuple[float, float]:
    """One motion: how far joint 3 swung out from where it started, and where it ended."""
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    state, period = control.readOnce()
    time, q3_start, reach = 0.0, state.q[2], 0.0
    while True:
        time += period.to_sec()
        reach = max(reach, abs(state.q[2] - q3_start))
        command = pylibfranka.JointVelocities([0.0, 0.0, omega(time), 0.0, 0.0, 0.0, 0.0])
        command.motion_finished = time >= 2 * TIME_MAX
        control.writeOnce(command)
        if command.motion_finished:
            return reach, state.q[2]
        state, period = control.readOnce()


def main(host: str, motions: int = MOTIONS) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    set_default_behavior(robot)
    pp.move_joints(robot, pp.READY)
    print("Finished moving to the ready pose.")
    robot.set_collision_behavior(TORQUE_THRESHOLDS, TORQUE_THRESHOLDS,
                                 FORCE_THRESHOLDS, FORCE_THRESHOLDS)
    finished = 0
    for i in range(motions):
        print(f"Executing motion {i + 1}.")
        try:
            reach, q3 = swing(robot)
        except pylibfranka.ControlException as error:
            print(error)
            print("Running error recovery...")
            robot.automatic_error_recovery()
        else:
            finished += 1
            print(f"Finished motion {i + 1}: joint 3 swung {reach:.4f} rad out and back "
                  f"to {q3:+.5f} rad.")
    print(f"Finished: {finished} of {motions} motions completed.")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         int(sys.argv[2]) if len(sys.argv) > 2 else MOTIONS)
