"""Press the Hand down on the table with a PI force controller written in torque control.

A port of libfranka's force_control example to pylibfranka. That example expects the arm to
rest on a horizontal surface already; here the arm first gets there: a joint motion to a pose
5 cm above the table (clear of the default scene's cube), then a slow one down until the
fingertips touch. The controller then renders, along the base's z axis, the weight of a mass:
it wants the external joint torque tau_ext = tau_J − g − (its value at the start) to equal
Jᵀ·(0, 0, −m·g, 0, 0, 0) and commands that torque plus a PI correction on the difference
(the robot adds gravity compensation). The mass rises from 0 to TARGET_MASS through a
first-order filter (time constant 1 s), so the press builds up over a few seconds. Like the original, it gives up
if the end effector strays more than 1 cm from where it started; unlike it, it stops on its
own after SECONDS and reports the external force it measured (O_F_ext_hat_K, z) and how far
the end effector drifted.

Run it against franka-sim on its default scene (a table under the arm):
    python force_control.py HOST [SECONDS]
"""

from __future__ import annotations

import sys
from typing import NamedTuple

import numpy as np
import pylibfranka

import pick_and_place as pp  # the offline IK and joint motions of the pick-and-place example
from examples_common import set_default_behavior

TARGET_MASS = 1.0  # kg: the press is the weight of this mass
K_P = 1.0  # on the torque error
K_I = 2.0  # 1/s, on its integral
FILTER_GAIN = 0.001  # per cycle: the mass approaches TARGET_MASS with a 1 s time constant
GRAVITY = 9.81  # m/s²
MAX_DRIFT = 0.01  # m from the start position: beyond it the example gives up

SPOT = (0.4, -0.2)  # on the table, clear of the cube at (0.45, 0)
TOUCH = 0.0095  # m: TCP height at which the fingertips touch the table (tips 9.5 mm beyond it)
PRELOAD = 0.0005  # m below the touch: the fingertips rest on the table, barely pressing
REPORT_EVERY = 1.0  # s


class Sample(NamedTuple):
    t: float  # s since the controller started
    force_d: float  # N: the desired force along z, −m·g
    force: float  # N: O_F_ext_hat_K z, the robot's estimate of the force it exerts
    drift: float  # m: how far the end effector is from where the controller started


def move_onto_table(robot: pylibfranka.Robot) -> None:
    """Above SPOT, then slowly down until the fingertips rest on the table."""
    above = pp.solve_ik([*SPOT, TOUCH + 0.05], pp.READY)
    pp.move_joints(robot, above)
    pp.move_joints(robot, pp.solve_ik([*SPOT, TOUCH - PRELOAD], above), max_speed=0.1)


def press(robot: pylibfranka.Robot, seconds: float) -> tuple[list[Sample], str | None]:
    """Run the force controller for `seconds`: a Sample per cycle, and why it gave up (None if it
    did not)."""
    model = robot.load_model()
    # Collisions only above 100 N / 100 Nm: the press must not trip the reflex.
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    initial = robot.read_once()
    gravity = np.array(model.gravity(initial))  # taken once, as the original does
    tau_ext_initial = np.array(initial.tau_J) - gravity  # the torque sensor's bias
    integral = np.zeros(7)
    mass, time, start = 0.0, 0.0, None
    samples, gave_up = [], None

    control = robot.start_torque_control()
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        position = np.array(state.O_T_EE[12:15])
        start = position if start is None else start
        drift = float(np.linalg.norm(position - start))
        J = np.reshape(model.zero_jacobian(state), (6, 7), order="F")
        force_d = -mass * GRAVITY
        tau_ext = np.array(state.tau_J) - gravity - tau_ext_initial
        tau_d = J[2] * force_d  # Jᵀ·(0, 0, force_d, 0, 0, 0)
        integral += period.to_sec() * (tau_d - tau_ext)
        tau = tau_d + K_P * (tau_d - tau_ext) + K_I * integral
        samples.append(Sample(time, force_d, state.O_F_ext_hat_K[2], drift))
        mass = FILTER_GAIN * TARGET_MASS + (1.0 - FILTER_GAIN) * mass
        if drift > MAX_DRIFT:
            gave_up = f"{drift * 1000:.1f} mm away from the start position after {time:.3f} s"
        command = pylibfranka.Torques(tau.tolist())
        command.motion_finished = gave_up is not None or time >= seconds
        control.writeOnce(command)
        if command.motion_finished:
            return samples, gave_up


def report(samples: list[Sample]) -> None:
    """One line per REPORT_EVERY seconds, then the force over the last half of the run and how
    far it strayed from its target: the desired force on top of the force the press started
    with (the controller's bias removes that one)."""
    shown = -1
    for sample in samples:
        if int(sample.t / REPORT_EVERY) != shown:
            shown = int(sample.t / REPORT_EVERY)
            print(f"t={sample.t:5.2f} s  desired F_z={sample.force_d:+6.2f} N  "
                  f"O_F_ext_hat_K z={sample.force:+6.2f} N  drift={sample.drift * 1000:.3f} mm")
    start, end = samples[0].force, samples[-1].t
    last = np.array([s.force for s in samples if s.t >= end / 2])
    print(f"O_F_ext_hat_K z over the last {end / 2:.1f} s: min {last.min():+.2f} N, "
          f"mean {last.mean():+.2f} N, max {last.max():+.2f} N "
          f"(target {-TARGET_MASS * GRAVITY:+.2f} N on the {start:+.2f} N it started at)")
    error = max(abs(s.force - (s.force_d + start)) for s in samples)
    print(f"largest distance of the force from its target: {error:.2f} N")
    print(f"largest drift {max(s.drift for s in samples) * 1000:.3f} mm, "
          f"final {samples[-1].drift * 1000:.3f} mm")


def main(host: str, seconds: float = 10.0) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    set_default_behavior(robot)
    move_onto_table(robot)
    samples, gave_up = press(robot, seconds)
    report(samples)
    if gave_up:
        sys.exit(f"aborted: {gave_up}")
    print("Finished: held the force for", f"{samples[-1][0]:.3f} s")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         float(sys.argv[2]) if len(sys.argv) > 2 else 10.0)
