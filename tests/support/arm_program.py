"""One arm's client program, as a user runs one per arm: a pylibfranka joint-position motion.

    python tests/support/arm_program.py HOST DELTA_Q_JSON SECONDS [THRESHOLD]

moves the arm from where it is by DELTA_Q (7 numbers, rad) along a cosine blend (collision
thresholds: THRESHOLD Nm and N, default 20, lower and upper alike), printing
"started" once the motion runs (so a test may kill it mid-motion), then one JSON line: the final
q, the smallest success rate seen after the motion's first states, the largest external
torque felt (|tau_ext_hat_filtered|, Nm), and the error a ControlException reported ("" if
none).
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pylibfranka


def run(host: str, delta, seconds: float, threshold: float = 20.0) -> dict:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([threshold] * 7, [threshold] * 7, [threshold] * 6,
                                 [threshold] * 6)
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0 = np.array(state.q_d)
    target = q0 + np.asarray(delta, dtype=float)
    print("started", flush=True)
    time, rates, error, k, felt = 0.0, [], "", 0, 0.0
    try:
        while True:
            state, period = control.readOnce()
            time += period.to_sec()
            k += 1
            if k > 3:  # the first states of a motion count cycles from before it
                rates.append(state.control_command_success_rate)
            felt = max(felt, float(np.abs(state.tau_ext_hat_filtered).max()))
            s = 0.5 * (1 - math.cos(math.pi * min(time / seconds, 1.0)))
            command = pylibfranka.JointPositions((q0 + s * (target - q0)).tolist())
            command.motion_finished = time >= seconds
            control.writeOnce(command)
            if command.motion_finished:
                break
    except pylibfranka.ControlException as exc:
        error = str(exc)
    final = robot.read_once()
    return {"q": list(final.q), "target": target.tolist(), "min_rate": min(rates, default=0.0),
            "error": error, "contact": list(final.joint_contact), "max_tau_ext": felt,
            "errors": str(final.last_motion_errors)}


if __name__ == "__main__":
    print(json.dumps(run(sys.argv[1], json.loads(sys.argv[2]), float(sys.argv[3]),
                         *(float(a) for a in sys.argv[4:5]))), flush=True)
