"""What recording costs: the same 1 kHz pylibfranka control loop (realtime clock) without and
with `serve --record`. Prints the success rate, the server's CPU % of a core (and its physics
thread's: recording must not cost the cycle its deadline), the rest (the loop and the
recorder's writer thread), and the
file's size per minute of control.

python benchmarks/record.py [--seconds 10] [--mode torque|joint]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

from _common import Load, cpu_seconds, thread_cpu_seconds
from control_loop import PHYSICS_THREAD, PRIVATE_HOST, control
from franka_sim.testing import ServerProcess

def run(args, record: Path | None) -> dict:
    flags = ["--clock", "realtime"] + (["--record", str(record)] if record else [])
    server = ServerProcess(args.host, *flags).wait_ready()
    try:
        cpu0, threads0 = cpu_seconds(server.pid), thread_cpu_seconds(server.pid)
        load = Load(exclude={server.pid})
        result = control(args.host, args.seconds, args.mode)
        other, _ = load.stop()
        wall = result["wall"]
        threads = {name: (s - threads0.get(name, 0.0)) / wall * 100
                   for name, s in thread_cpu_seconds(server.pid).items()}
        result.update(cpu=(cpu_seconds(server.pid) - cpu0) / wall * 100, other=other,
                      physics=threads.get(PHYSICS_THREAD, 0.0))
    finally:
        server.stop()
    if record:
        result["mib_per_minute"] = record.stat().st_size / 2**20 / (result["sim"] / 60)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds of control")
    parser.add_argument("--mode", choices=["torque", "joint"], default="joint")
    parser.add_argument("--host", default=PRIVATE_HOST)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        plain = run(args, None)
        recorded = run(args, Path(tmp, "run.mcap"))
    print(f"recording overhead: {args.mode} control, realtime clock, {args.seconds:g} s, "
          f"{os.cpu_count()} CPUs")
    for name, r in (("without", plain), ("with --record", recorded)):
        print(f"  {name:14} success {r['mean_rate']:.4f} (min {r['min_rate']:.4f})  "
              f"server CPU {r['cpu']:5.1f} %  physics thread {r['physics']:5.1f} %  "
              f"rest (loop, recorder) {r['cpu'] - r['physics']:5.1f} %  (others used {r['other']:.0f} %)")
    print(f"  file size: {recorded['mib_per_minute']:.1f} MiB per minute of control")


if __name__ == "__main__":
    main()
