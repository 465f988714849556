"""RobotState stream quality seen by a minimal raw UDP client, plus the server's CPU and RSS.

    python benchmarks/stream.py --seconds 10
    python benchmarks/stream.py --host 127.0.0.1 --pid 1234   # an already-running server
    python benchmarks/stream.py --reference   # same figures for reference_sender.py (the floor)
    python benchmarks/stream.py --rt-priority 20   # server and this client under SCHED_FIFO

The verdicts on intervals use the kernel's arrival time of each datagram (SO_TIMESTAMPNS): when
the state reached this client's socket, which is what the server controls. The "recv" column
adds this Python client's own wake-up delay; it is printed for comparison.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from _common import (PRIVATE_HOST, Load, cpu_percent, cpu_seconds, idle_behaviour, memory_mib,
                     reference_command, verdict)
from franka_sim.testing import RawClient, ServerProcess


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0, help="measured window (default 10)")
    ap.add_argument("--warmup", type=float, default=1.0, help="states discarded first (s)")
    ap.add_argument("--idle-seconds", type=float, default=3.0,
                    help="server CPU with no client, measured before connecting (0: skip)")
    ap.add_argument("--host", help="use an already-running server on this address")
    ap.add_argument("--pid", type=int, help="its pid, for CPU/RSS (with --host)")
    ap.add_argument("--reference", action="store_true",
                    help="measure reference_sender.py instead of franka-sim (platform floor)")
    ap.add_argument("--rt-priority", type=int, default=0,
                    help="serve with --rt-priority N and run this client under SCHED_FIFO N too, "
                    "as libfranka runs its own (needs root or CAP_SYS_NICE)")
    args = ap.parse_args()

    if args.reference:
        command, serve_args = reference_command(PRIVATE_HOST), []
    else:
        command = None
        serve_args = ["--rt-priority", str(args.rt_priority)] if args.rt_priority else []
    if args.rt_priority:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(args.rt_priority))
        except OSError as exc:
            print(f"client stays at normal priority: {exc}")
    server = None if args.host else ServerProcess(PRIVATE_HOST, *serve_args, command=command)
    host = args.host or PRIVATE_HOST
    pid = server.pid if server else args.pid
    try:
        if server:
            server.wait_ready()  # "serving on": franka-sim's log line, also printed by the reference
            time.sleep(1.0)  # let start-up work settle before the idle figure
        idle_cpu = cpu_percent(pid, args.idle_seconds) if pid and args.idle_seconds > 0 else None

        client = RawClient(host, first_state=False, receive_buffer=4 << 20)
        t_end = time.perf_counter_ns() + int(args.warmup * 1e9)
        while client.recv_timed()[0] < t_end:
            pass
        times, ids, ktimes = [], [], []
        cpu0 = cpu_seconds(pid) if pid else None
        load = Load(exclude={pid} if pid else set())
        w0 = time.perf_counter_ns()
        t_end = w0 + int(args.seconds * 1e9)
        t = w0
        while t < t_end:
            t, mid, kt = client.recv_timed()
            times.append(t)
            ids.append(mid)
            ktimes.append(kt)
        w1 = time.perf_counter_ns()
        other_cpu, pressure = load.stop()
        cpu = 100 * (cpu_seconds(pid) - cpu0) / ((w1 - w0) / 1e9) if pid else None
        rss, anon = memory_mib(pid) if pid else (None, None)
        client.close()
    finally:
        if server:
            server.stop()

    t = np.array(times, dtype=np.int64)
    did = np.diff(np.array(ids, dtype=np.int64))
    rate = (len(t) - 1) / ((t[-1] - t[0]) / 1e9)
    skipped = int((did[did > 1] - 1).sum())
    backwards = int((did <= 0).sum())
    app = intervals(t)  # when this process got each state (what the brief's targets apply to)
    kern = intervals(np.array(ktimes, dtype=np.int64))  # when the kernel queued it

    what = "reference_sender.py" if args.reference else "franka-sim"
    print(f"{what} stream, {args.seconds:g} s window after {args.warmup:g} s warm-up, "
          f"host {host}{'' if server else ' (external server)'}")
    print(f"  machine: {os.cpu_count()} CPUs; during the window other processes used "
          f"{other_cpu:.0f} % of a core, tasks waited for a CPU {pressure:.0f} % of the time"
          f"{idle_behaviour()}")
    print(f"  {'':<42} {'recv':>10} {'kernel':>8}   {'target':<11}")
    rows = [
        ("states received", f"{len(t)}", "", None, ""),
        ("states/s (count/wall)", f"{rate:.2f}", "1000 ± 0.5", abs(rate - 1000) <= 0.5, ""),
    ]
    for key, target, ok in [
        ("p50", "", None), ("p99", "≤ 1.05", kern["p99"] <= 1.05), ("p99.9", "", None),
        ("max", "≤ 2", kern["max"] <= 2.0), ("min", "", None),
    ]:
        rows.append((f"interval {key} ms", f"{app[key]:.3f}", target, ok, f"{kern[key]:.3f}"))
    rows += [
        ("intervals < 0.5 ms", f"{app['short']}", "0", kern["short"] == 0, f"{kern['short']}"),
        ("message_ids skipped", f"{skipped}", "", None, ""),
        ("message_ids not increasing", f"{backwards}", "", None, ""),
    ]
    if cpu is not None:
        rows += [
            ("server CPU % of a core (streaming)", f"{cpu:.1f}", "≤ 15", cpu <= 15, ""),
            ("server RSS MiB", f"{rss:.1f}", "≤ 65", rss <= 65, ""),
            ("  of which its own (anonymous, not shared)", f"{anon:.1f}", "", None, ""),
        ]
    if idle_cpu is not None:
        rows.append(("server CPU % of a core (idle, no client)", f"{idle_cpu:.1f}", "", None, ""))
    for name, value, target, ok, kernel in rows:
        mark = "" if ok is None else verdict(ok)
        print(f"  {name:<42} {value:>10} {kernel:>8}   {target:<11} {mark}")


def intervals(ns: np.ndarray) -> dict:
    dt = np.diff(ns) / 1e6
    p50, p99, p999 = np.percentile(dt, [50, 99, 99.9])
    return {"p50": p50, "p99": p99, "p99.9": p999, "max": dt.max(), "min": dt.min(),
            "short": int((dt < 0.5).sum())}


if __name__ == "__main__":
    main()
