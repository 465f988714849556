"""What each further simulated arm costs a machine in memory: N servers side by side.

Starts `franka-sim serve` on 127.0.0.201, .202, … one after the other and prints, for each, the
drop in the kernel's MemAvailable once it serves and has settled, with its resident set (RSS)
and the anonymous (unshared) part of it. The RSS counts the libraries' code pages, which every
server maps from the same files and the kernel keeps once: the drop per further server is close
to the anonymous part, not to the RSS. MemAvailable moves with everything else on the machine
too, so run it on a quiet one.

    python benchmarks/fleet_memory.py [--servers 4]
"""

from __future__ import annotations

import argparse
import time

from _common import memory_mib
from franka_sim.testing import ServerProcess


def mem_available_mib() -> float:
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no MemAvailable in /proc/meminfo")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--servers", type=int, default=4, help="how many servers (default 4, ≤ 50)")
    ap.add_argument("--settle", type=float, default=2.0, help="s to wait after each start")
    args = ap.parse_args()
    if not 1 <= args.servers <= 50:
        ap.error("--servers must be 1..50")
    servers: list[ServerProcess] = []
    try:
        print(f"{'server':<16} {'MemAvailable drop MiB':>22} {'RSS MiB':>9} {'anonymous MiB':>14}")
        for k in range(args.servers):
            before = mem_available_mib()
            server = ServerProcess(f"127.0.0.{201 + k}")
            servers.append(server)
            server.wait_ready()
            time.sleep(args.settle)
            drop = before - mem_available_mib()
            rss, anon = memory_mib(server.pid)
            print(f"{server.host:<16} {drop:>22.1f} {rss:>9.1f} {anon:>14.1f}")
    finally:
        for server in servers:
            server.stop()


if __name__ == "__main__":
    main()
