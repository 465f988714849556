"""Several arms in one world: what each further arm costs, every arm under its own 1 kHz client.

For N arms (default 1, 2 and 4) one `franka-sim serve` with N `--arm`s, and N pylibfranka
torque loops, one process per arm (as a user runs them). Printed per N:
- realtime: each client's success rate (mean, min after the first 200 cycles) and the server's
  CPU, in % of one core, in all and per arm; the server's RSS;
- lockstep: simulated seconds per wall second with every arm's loop running.
The target: on a 2-core machine two arms keep 1 kHz with success >= 0.999 in realtime.

python benchmarks/arms.py [--arms 1 2 4] [--seconds 10]
"""

from __future__ import annotations

import argparse
import multiprocessing
import time

import numpy as np
import pylibfranka

from _common import cpu_seconds, idle_behaviour, memory_mib, verdict
from _torque_loop import torque_loop

SPACING = 1.0  # m between neighbouring bases, along y: no arm reaches another


def _client(host: str, seconds: float, out) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    loop = torque_loop(robot, seconds)
    rates = loop["rates"][200:]
    stamps = loop["stamps"]
    speed = len(stamps) / 1000 / (stamps[-1] - stamps[0])  # simulated s per wall s
    out.put((host, float(rates.mean()), float(rates.min()), speed))


def _serve(n: int, clock: str):
    from franka_sim.testing import ServerProcess

    hosts = [f"127.0.0.{210 + i}" for i in range(n)]
    arms = [a for i, host in enumerate(hosts)
            for a in ("--arm", f"arm{i}={host}@0,{(i - (n - 1) / 2) * SPACING},0")]
    return ServerProcess(hosts[0], *arms, "--clock", clock, "--control-port", "0"), hosts


def _run(n: int, clock: str, seconds: float) -> tuple[list, float, float, float]:
    """(client results, server CPU %, RSS MiB, wall seconds) of N clients for `seconds`."""
    server, hosts = _serve(n, clock)
    server.wait_ready()
    try:
        pid = server.proc.pid
        out = multiprocessing.get_context("spawn").Queue()
        clients = [multiprocessing.get_context("spawn").Process(
            target=_client, args=(host, seconds, out)) for host in hosts]
        for client in clients:
            client.start()
        time.sleep(1.0)  # connected and streaming
        c0, t0 = cpu_seconds(pid), time.perf_counter()
        results = [out.get(timeout=seconds * 20 + 60) for _ in clients]
        wall = time.perf_counter() - t0
        cpu = 100 * (cpu_seconds(pid) - c0) / wall
        for client in clients:
            client.join()
        rss = memory_mib(pid)[0]
    finally:
        server.stop()
    return results, cpu, rss, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    for n in args.arms:
        results, cpu, rss, _ = _run(n, "realtime", args.seconds)
        worst = min(r[2] for r in results)
        mean = np.mean([r[1] for r in results])
        print(f"{n} arm(s), realtime: success mean {mean:.4f} min {worst:.4f}; server CPU "
              f"{cpu:.1f} % ({cpu / n:.1f} % per arm); RSS {rss:.1f} MiB{idle_behaviour()}")
        if n == 2:
            print(f"  two arms keep 1 kHz with success >= 0.999: {verdict(worst >= 0.999)}")
        results, _, _, _ = _run(n, "lockstep", args.seconds)
        print(f"{n} arm(s), lockstep: {min(r[3] for r in results):.2f} simulated s per wall s "
              "(every arm's loop running)")


if __name__ == "__main__":
    main()
