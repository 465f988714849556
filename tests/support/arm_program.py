"""One arm's client program, as a user runs one per arm: a pylibfranka joint-position motion.

    python tests/support/arm_program.py HOST DELTA_Q_JSON SECONDS [THRESHOLD]
        [--push BODY] [--hand WIDTH]

moves the arm from where it is by DELTA_Q (7 numbers, rad) along a cosine blend (collision
thresholds: THRESHOLD Nm and N, default 20, lower and upper alike), printing
"started" once the motion runs (so a test may kill it mid-motion), then one JSON line: the final
q, the smallest success rate seen after the motion's first states, the largest external
torque felt (|tau_ext_hat_filtered|, Nm), and the error a ControlException reported ("" if
none).

--together: connected and configured, print "ready" and wait for a line on stdin before the
motion starts (so a test starts several arms' motions at once, however long each process took
to start).

--push BODY: halfway through the motion, push BODY (5 N along +x for 50 ms) through the
simulator's control API on HOST, from within the control loop (between reading a state and
answering it), so that in lockstep it lands on the same cycle in every run. --hand WIDTH: after
the motion, move the Franka Hand to WIDTH (m) at 0.1 m/s; the JSON then has "hand": whether
the move succeeded and the width it reached.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
import pylibfranka

PUSH_FORCE = [5.0, 0.0, 0.0]  # N: felt, yet far below the collision thresholds
PUSH_SECONDS = 0.05


def run(host: str, delta, seconds: float, threshold: float = 20.0, *, push: str = "",
        hand: float | None = None, together: bool = False) -> dict:
    # Ready before the motion: importing it inside the loop would hold the loop up for tens of
    # ms, which in realtime loses 20 cycles in a row; the push itself takes a few ms.
    pusher = _pusher(host, push) if push else None
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([threshold] * 7, [threshold] * 7, [threshold] * 6,
                                 [threshold] * 6)
    if together:
        print("ready", flush=True)
        sys.stdin.readline()
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0 = np.array(state.q_d)
    target = q0 + np.asarray(delta, dtype=float)
    print("started", flush=True)
    time, rates, error, k, felt, pushed = 0.0, [], "", 0, 0.0, None
    try:
        while True:
            state, period = control.readOnce()
            time += period.to_sec()
            k += 1
            if k > 3:  # the first states of a motion count cycles from before it
                rates.append(state.control_command_success_rate)
            felt = max(felt, float(np.abs(state.tau_ext_hat_filtered).max()))
            if pusher and pushed is None and time >= seconds / 2:
                pushed = pusher()
            s = 0.5 * (1 - math.cos(math.pi * min(time / seconds, 1.0)))
            command = pylibfranka.JointPositions((q0 + s * (target - q0)).tolist())
            command.motion_finished = time >= seconds
            control.writeOnce(command)
            if command.motion_finished:
                break
    except pylibfranka.ControlException as exc:
        error = str(exc)
    final = robot.read_once()
    out = {"q": list(final.q), "target": target.tolist(), "min_rate": min(rates, default=0.0),
           "error": error, "contact": list(final.joint_contact), "max_tau_ext": felt,
           "errors": str(final.last_motion_errors), "pushed": pushed}
    if hand is not None:
        out["hand"] = _move_hand(host, hand)
    return out


def _pusher(host: str, body: str):
    from franka_sim.control import Control  # only a pushing program needs it

    control = Control(host)
    return lambda: control.push(body, force=PUSH_FORCE, duration=PUSH_SECONDS)


def _move_hand(host: str, width: float) -> dict:
    gripper = pylibfranka.Gripper(host)
    ok = gripper.move(width, 0.1)
    return {"ok": bool(ok), "width": float(gripper.read_once().width)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("host")
    parser.add_argument("delta", type=json.loads)
    parser.add_argument("seconds", type=float)
    parser.add_argument("threshold", type=float, nargs="?", default=20.0)
    parser.add_argument("--push", default="")
    parser.add_argument("--hand", type=float)
    parser.add_argument("--together", action="store_true")
    a = parser.parse_args()
    print(json.dumps(run(a.host, a.delta, a.seconds, a.threshold, push=a.push, hand=a.hand,
                         together=a.together)), flush=True)


if __name__ == "__main__":
    main()
