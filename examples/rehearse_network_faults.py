"""Rehearses a network outage: a burst of lost cycles in the middle of a motion trips
communication_constraints_violation; the program recovers and runs the motion again.

Serve the burst where the motion will be: 3 s of simulated time falls within the first 4 s
motion (a fresh lockstep simulator's clock stands near 0 s until a client comes, a realtime
one's at about 2 s). The burst is keyed on the robot's clock, which a reset does not rewind:
serve a fresh simulator for each rehearsal.

    franka-sim serve --clock lockstep --enforce-comm-constraints --inject burst=25@3s
    python rehearse_network_faults.py HOST [SECONDS]

Exits 1 if the first motion met no fault (the burst was not within it).
"""

import math
import sys

import pylibfranka

AMPLITUDE = 0.15  # rad, joints 4 and 6 swing out and back


def swing(robot: pylibfranka.Robot, seconds: float) -> tuple[float, float]:
    """Joints 4 and 6 out and back in `seconds` (cosine, at rest at both ends); returns the
    robot time [s] at which it started and the success rate at its end."""
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0, start, t = list(state.q_d), state.time.to_sec(), 0.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        s = AMPLITUDE * 0.5 * (1 - math.cos(2 * math.pi * min(t / seconds, 1.0)))
        q = list(q0)
        q[3] += s
        q[5] += s
        command = pylibfranka.JointPositions(q)
        command.motion_finished = t >= seconds
        control.writeOnce(command)
        if command.motion_finished:
            return start, state.control_command_success_rate


def main(host: str, seconds: float = 4.0) -> int:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    try:
        start, _ = swing(robot, seconds)
    except pylibfranka.ControlException as exc:
        state = robot.read_once()
        print(f"motion aborted at t={state.time.to_sec():.3f} s: {exc}")
        print(f"mode={state.robot_mode.name} last_motion_errors={state.last_motion_errors}")
    else:
        print(f"the motion from t={start:.3f} s met no fault: serve a burst within it")
        return 1
    robot.automatic_error_recovery()
    robot.read_once()  # (what the socket kept while the recovery ran: up to ~100 ms old)
    print(f"recovered: mode={robot.read_once().robot_mode.name}")
    start, rate = swing(robot, seconds)
    print(f"Finished motion (from t={start:.3f} s), success_rate={rate:.2f}, "
          f"mode={robot.read_once().robot_mode.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
                  float(sys.argv[2]) if len(sys.argv) > 2 else 4.0))
