"""Start-up and shut-down time of `franka-sim serve`.

Per run: spawn → "serving on" on stderr, spawn → first RobotState at a raw client (which
connects as soon as that line appears), and SIGTERM → exit (with the client still connected).
`--alternative "CMD"` starts another simulator (e.g. franka-sim 1.1.7, docs/benchmarks.md) in
the same run, alternated with ours, and prints its spawn → first RobotState beside ours.

franka_sim's bytecode is compiled first, as `pip install` does: a source tree run with
PYTHONDONTWRITEBYTECODE set (as some shells and images are) would otherwise compile every
module at every start (~60 ms here), which no installed copy does.

    python benchmarks/startup.py [--runs 5] [--alternative CMD]
"""

from __future__ import annotations

import argparse
import compileall
import statistics
import time
from pathlib import Path

from _common import PRIVATE_HOST, start_server
from franka_sim.testing import RawClient

FIRST_STATE_TARGET = 0.25  # s, spawn → first RobotState


def once(host: str, alternative: str | None) -> tuple[float, float, float]:
    """(spawn → ready line, spawn → first state, SIGTERM → exit) of one start."""
    server = start_server(host, alternative)
    try:
        serving = server.serving_after
        client = RawClient(host, first_state=False)
        client.recv_timed()
        first = time.perf_counter() - server.spawned_at
        stop = server.stop()
        client.close()
    finally:
        server.stop()
    return serving, first, stop


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--runs", type=int, default=5, help="repetitions (default 5)")
    ap.add_argument("--host", default=PRIVATE_HOST, help=f"address to serve on ({PRIVATE_HOST})")
    ap.add_argument("--alternative", help="another simulator's command ({host}: the address)")
    args = ap.parse_args()
    import franka_sim

    compileall.compile_dir(Path(franka_sim.__file__).parent, quiet=1)
    ours, theirs = [], []
    for _ in range(args.runs):
        ours.append(once(args.host, None))
        if args.alternative:
            theirs.append(once(args.host, args.alternative))

    print(f"franka-sim serve start/stop, {args.runs} runs on {args.host}")
    serving, first, stop = zip(*ours)
    for name, xs, target, limit in [
        ('spawn → "serving on" log line', serving, "< 1 s", 1.0),
        ("spawn → first RobotState", first, f"≤ {FIRST_STATE_TARGET} s", FIRST_STATE_TARGET),
        ("SIGTERM → exit", stop, "well < 1 s", 0.5),
    ]:
        _row(name, xs, target, limit)
    if theirs:
        _row("alternative: spawn → first state", [t[1] for t in theirs], "", float("inf"))
        ratio = statistics.median(first) / statistics.median([t[1] for t in theirs])
        print(f"  first state, franka-sim / alternative (medians)  {ratio:.2f}×")


def _row(name: str, xs, target: str, limit: float) -> None:
    med, worst = statistics.median(xs), max(xs)
    ok = "ok" if worst <= limit else "MISS"
    print(f"  {name:<32} median {1e3 * med:7.1f} ms   max {1e3 * worst:7.1f} ms"
          f"   target {target:<10} {ok if target else ''}")


if __name__ == "__main__":
    main()
