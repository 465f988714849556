"""Press the Hand down on the table and watch the robot's estimate of the force it exerts.

The Cartesian impedance controller tracks a pose that goes 1 cm below where the fingertips touch
the table, holds it for a second and comes back up. Pressing, the spring of stiffness K_z pushes
down with K_z·(z_d − z); the robot reports that force in O_F_ext_hat_K (negative z: a force the
robot exerts on its environment is positive along its direction) and in K_F_ext_hat_K (K's z
axis points down out of the hand, so there it is positive), and flags a Cartesian contact above
the lower threshold set here (5 N). Every 0.25 s one line shows the estimate next to the spring.

Run it against franka-sim on its default scene (a table under the arm):
    python press_on_table.py HOST
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pylibfranka

import pick_and_place as pp  # the offline IK and joint motions of the pick-and-place example

K_X = [1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0]  # N/m, Nm/rad
TOUCH = 0.0095  # m: TCP height at which the fingertips touch the table (tips 9.5 mm beyond it)
SPOT = (0.35, 0.2)  # on the table, clear of the cube
DEPTH = 0.03  # m: from 2 cm above the touch to 1 cm below it
DOWN, HOLD = 1.0, 1.0  # s


def height_offset(t: float) -> float:
    """How far under its start the commanded pose is at time t: down, hold, up."""
    if t < DOWN:
        return DEPTH * 0.5 * (1 - math.cos(math.pi * t / DOWN))
    if t < DOWN + HOLD:
        return DEPTH
    return DEPTH * 0.5 * (1 + math.cos(math.pi * min(t - DOWN - HOLD, DOWN) / DOWN))


def main(host: str) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    # Contact above 5 N; a collision (reflex) only above 100 N / 100 Nm.
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [5.0] * 6, [100.0] * 6)
    robot.set_cartesian_impedance(K_X)
    pp.move_joints(robot, pp.solve_ik([*SPOT, TOUCH + 0.02], pp.READY))

    control = robot.start_cartesian_pose_control(pylibfranka.ControllerMode.CartesianImpedance)
    state, _ = control.readOnce()
    start = np.reshape(state.O_T_EE_c, (4, 4), order="F")
    t, shown = 0.0, -1
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        target = start.copy()
        target[2, 3] -= height_offset(t)
        if int(t / 0.25) != shown:
            shown = int(t / 0.25)
            z = np.reshape(state.O_T_EE, (4, 4), order="F")[2, 3]
            spring = K_X[2] * (target[2, 3] - z)
            wrench = ", ".join(f"{v:+.2f}" for v in state.O_F_ext_hat_K)
            contact = list(map(int, state.cartesian_contact))
            print(f"t={t:4.2f} s  z={z:+.4f} m  spring K_z·(z_d − z)={spring:+7.2f} N  "
                  f"O_F_ext_hat_K=[{wrench}]  K_F_z={state.K_F_ext_hat_K[2]:+.2f} N  "
                  f"contact={contact}")
        command = pylibfranka.CartesianPose(target.ravel(order="F").tolist())
        command.motion_finished = t >= 2 * DOWN + HOLD
        control.writeOnce(command)
        if command.motion_finished:
            break
    del control
    pp.move_joints(robot, pp.READY)
    print("lifted off: cartesian_contact", list(map(int, robot.read_once().cartesian_contact)))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
