"""Start-up and shut-down time of `franka-sim serve`.

Per run: spawn → "serving on" on stderr, spawn → first RobotState at a raw client (which
connects as soon as that line appears), and SIGTERM → exit (with the client still connected).

    python benchmarks/startup.py [--runs 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

from _common import PRIVATE_HOST
from franka_sim.testing import RawClient, ServerProcess


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--runs", type=int, default=5, help="repetitions (default 5)")
    ap.add_argument("--host", default=PRIVATE_HOST, help=f"address to serve on ({PRIVATE_HOST})")
    args = ap.parse_args()

    serving, first, stop = [], [], []
    for _ in range(args.runs):
        server = ServerProcess(args.host)
        try:
            serving.append(server.wait_ready().serving_after)
            client = RawClient(args.host, first_state=False)
            client.recv_timed()
            first.append(time.perf_counter() - server.spawned_at)
            stop.append(server.stop())
            client.close()
        finally:
            server.stop()

    print(f"franka-sim serve start/stop, {args.runs} runs on {args.host}")
    for name, xs, target, limit in [
        ('spawn → "serving on" log line', serving, "< 1 s", 1.0),
        ("spawn → first RobotState", first, "< 1 s", 1.0),
        ("SIGTERM → exit", stop, "well < 1 s", 0.5),
    ]:
        med, worst = statistics.median(xs), max(xs)
        ok = "ok" if worst < limit else "MISS"
        print(f"  {name:<32} median {1e3 * med:7.1f} ms   max {1e3 * worst:7.1f} ms"
              f"   target {target:<10} {ok}")


if __name__ == "__main__":
    main()
