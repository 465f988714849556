"""µs per RobotState encode and per RobotCommand decode with franka_sim.protocol.codec (timeit).

    python benchmarks/codec.py [--number 20000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

from franka_sim.protocol.codec import StateBuffer, decode_command, encode_command

TARGET_US = 10.0
rng = np.random.default_rng(0)

# What the robot writes every cycle, as float64 like the physics hands it over.
q, dq, q_d, tau_J, dtau_J, theta, dtheta = (rng.standard_normal(7) for _ in range(7))
O_T_EE = rng.standard_normal(16)
O_T_EE_d = rng.standard_normal(16)
elbow = rng.standard_normal(2)
state = StateBuffer()


def encode_state(message_id: int = 42) -> bytes:
    s = state
    s.q[:] = q
    s.dq[:] = dq
    s.q_d[:] = q_d
    s.tau_J[:] = tau_J
    s.dtau_J[:] = dtau_J
    s.theta[:] = theta
    s.dtheta[:] = dtheta
    s.O_T_EE[:] = O_T_EE
    s.O_T_EE_d[:] = O_T_EE_d
    s.elbow[:] = elbow
    s.message_id[...] = message_id
    return s.pack()


command = encode_command(message_id=41, q_c=rng.standard_normal(7), motion_generation_finished=True)


def decode(data: bytes = command):
    rec = decode_command(data)
    return rec["q_c"], int(rec["message_id"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--number", type=int, default=20000, help="calls per timing (default 20000)")
    ap.add_argument("--repeat", type=int, default=5, help="timings; the best is kept (default 5)")
    args = ap.parse_args()

    assert len(encode_state()) == 1377 and len(command) == 371
    print(f"franka_sim.protocol.codec, best of {args.repeat} × {args.number} calls")
    for name, fn in [("RobotState encode (11 fields + pack)", encode_state),
                     ("RobotCommand decode (+ q_c, message_id)", decode)]:
        times = timeit.repeat(fn, number=args.number, repeat=args.repeat)
        best, median = min(times), sorted(times)[len(times) // 2]
        us = 1e6 * best / args.number
        ok = "ok" if us <= TARGET_US else "MISS"
        print(f"  {name:<40} {us:7.2f} µs  (median {1e6 * median / args.number:.2f})"
              f"   target ≤ {TARGET_US:g} µs  {ok}")


if __name__ == "__main__":
    main()
