"""What the real server costs per cycle under a real client, and where it goes.

Lockstep: a pylibfranka client (its own process) runs a suite of joint position motions (default
20 × 0.5 s, separate Moves, one connection) against `franka-sim serve --clock lockstep`. Prints
simulated s per wall s, and per motion cycle the wall time split into the server's CPU (and its
cycle thread's), the client's CPU and the rest (neither process on a CPU: hand-offs and wake-ups),
beside what benchmarks/cycle.py's tight loop spends on one cycle. The server runs more cycles
than the client answers (after each motion the world settles onto its hold): both counts show.
`--profile` samples the server with py-spy meanwhile and prints where its time went, by stage.

Realtime: a pylibfranka joint position loop with a pylibfranka.Gripper connected, `--seconds`
long: the server's CPU % of a core while controlling, with the client connected and idle, and
with no client. `--alternative "CMD"` measures another simulator (any command serving the same
protocol, e.g. franka-sim 1.1.7, see docs/benchmarks.md) in the same run, alternated.

`--cxx-example PATH`: a libfranka C++ example (generate_joint_position_motion and alike, built
against libfranka 0.21.3) run against the lockstep server: simulated s (message_ids the server
advanced) per wall s of the program.

`--pingpong`: the machine's bound, two processes handing a datagram back and forth on loopback
(benchmarks/pingpong.py): no server can answer a lockstep cycle in less wall time than that.

python benchmarks/server_cost.py [--clock lockstep|realtime|both] [--motions 20] [--seconds 0.5]
    [--profile] [--alternative CMD] [--runs 2] [--cxx-example PATH] [--pingpong]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import (Load, cpu_percent, cpu_seconds, idle_behaviour, memory_mib, start_server,
                     thread_cpu_seconds, verdict)
from franka_sim.control import Control
from franka_sim.server.clock import START_SPACING
from franka_sim.server.cycle_thread import OS_THREAD_NAME
from franka_sim.testing.realtime_kernel import as_realtime, cannot_fake

HOST = "127.0.0.204"
CYCLE_THREAD = OS_THREAD_NAME.decode()
HERE = Path(__file__).parent
TARGETS = {"speed": 6.0, "cpu_cycle": 60.0, "vs_alternative": 0.5, "rss": 62.0, "cxx": 15.0}

CLIENT = r'''
import json, math, sys, time
import numpy as np
import pylibfranka

host, mode, motions, seconds = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
gripper = pylibfranka.Gripper(host) if mode == "realtime" else None
if gripper is not None:
    gripper.read_once()


def motion(n):
    """(cycles, success rate, wall s from the Move to the first command's send)."""
    started = time.perf_counter()
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0, t, cycles, start = np.array(state.q_d), 0.0, 0, None
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        cycles += 1
        q = q0.copy()
        q[n % 7] += 0.1 * 0.5 * (1 - math.cos(2 * math.pi * min(t / seconds, 1.0)))
        out = pylibfranka.JointPositions(q.tolist())
        out.motion_finished = t >= seconds
        if start is None:
            start = time.perf_counter() - started
        control.writeOnce(out)
        if out.motion_finished:
            return cycles, state.control_command_success_rate, start


def step(name):
    print(name, flush=True)
    sys.stdin.readline()  # the parent has read its counters


step("ready")
wall0, cpu0, cycles, rates, starts = time.perf_counter(), time.process_time(), 0, [], []
for n in range(motions):
    done, rate, start = motion(n)
    cycles += done
    rates.append(rate)
    starts.append(start)
wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
step("done")
if gripper is not None:
    step("idle")  # connected, not moving: the parent measures meanwhile
print(json.dumps({"cycles": cycles, "wall": wall, "cpu": cpu, "min_rate": min(rates),
                  "starts": starts}), flush=True)
'''


class Client:
    """CLIENT in its own process, stepped by the parent between its phases."""

    def __init__(self, host: str, mode: str, motions: int, seconds: float) -> None:
        self.proc = subprocess.Popen([sys.executable, "-c", CLIENT, host, mode, str(motions),
                                      str(seconds)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True)

    def expect(self, name: str) -> None:
        line = self.proc.stdout.readline().strip()
        if line != name:
            raise RuntimeError(f"client said {line!r}, expected {name!r}")

    def go(self) -> None:
        self.proc.stdin.write("\n")
        self.proc.stdin.flush()

    def result(self) -> dict:
        out = json.loads(self.proc.stdout.readline())
        self.proc.wait(30)
        return out


def health_cycle(host: str) -> int:
    """The server's message_id (the control API's /health)."""
    return Control(host).health()["cycle"]


def profile(pid: int, out: Path) -> subprocess.Popen:
    """py-spy sampling `pid` until it is sent SIGINT (then it writes `out`)."""
    return subprocess.Popen(["py-spy", "record", "--pid", str(pid), "--rate", "997", "--format",
                             "raw", "--nonblocking", "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


# Stage of a sample: the first frame, walking from the leaf to the root, that one of these
# (function or None for any, a part of its file's path) matches.
STAGES = [
    ("world step (physics/)", None, "franka_sim/physics/"),
    ("state pack + publish", None, "robot/publisher.py"),
    ("state pack + publish", "pack", "protocol/codec.py"),
    ("sendto", "send_state", "udp_endpoint.py"),
    ("command read + decode", "read", "udp_endpoint.py"),
    ("command read + decode", "receive", "robot/"),
    ("lockstep: reading for the answer", "_await_answer", "cycle_driver.py"),
    ("checks after the state (complete)", "complete", "robot/"),
    ("the core's decision (release)", "release", "robot/"),
    ("clock + driver", None, "server/clock.py"),
    ("clock + driver", None, "server/cycle_driver.py"),
    ("waiting (select, sleep)", None, "server/cycle_thread.py"),
]


def stage_of(frames: list[tuple[str, str]]) -> str:
    for function, path in reversed(frames):
        for stage, name, part in STAGES:
            if part in path and name in (None, function):
                return stage
    return "other"


def print_profile(raw: Path) -> None:
    """py-spy's collapsed stacks: the share of samples per thread and, in the cycle thread, per
    stage (a sample's innermost known stage)."""
    threads: dict[str, int] = {}
    stages: dict[str, int] = {}
    total = 0
    for line in raw.read_text().splitlines():
        stack, _, count = line.rpartition(" ")
        frames = [(f.split(" (")[0].rsplit(".", 1)[-1], f.split(" (")[1] if " (" in f else "")
                  for f in stack.split(";")]
        n = int(count)
        total += n
        thread = "cycle thread" if any(fn == "_run" and "cycle_thread.py" in p
                                       for fn, p in frames) else "event loop + others"
        threads[thread] = threads.get(thread, 0) + n
        if thread == "cycle thread":
            stage = stage_of(frames)
            stages[stage] = stages.get(stage, 0) + n
    if not total:
        print("  (py-spy took no samples)")
        return
    print(f"  py-spy, {total} samples of the server (on a CPU):")
    for name, n in sorted(threads.items(), key=lambda kv: -kv[1]):
        print(f"    {name:<36}{100 * n / total:5.1f} %")
    for name, n in sorted(stages.items(), key=lambda kv: -kv[1]):
        print(f"      {name:<34}{100 * n / total:5.1f} %")


def lockstep(args) -> None:
    server = start_server(HOST, None, "--clock", "lockstep")
    try:
        client = Client(HOST, "lockstep", args.motions, args.seconds)
        client.expect("ready")
        cycle0 = health_cycle(HOST)
        cpu0, threads0 = cpu_seconds(server.pid), thread_cpu_seconds(server.pid)
        load = Load(exclude={server.pid, client.proc.pid})
        raw = Path(tempfile.mkdtemp(prefix="server-cost-")) / "server.raw"
        spy = profile(server.pid, raw) if args.profile else None
        client.go()
        client.expect("done")
        if spy is not None:
            spy.send_signal(signal.SIGINT)
        cpu = cpu_seconds(server.pid) - cpu0
        threads = thread_cpu_seconds(server.pid)
        cycle_cpu = threads.get(CYCLE_THREAD, 0.0) - threads0.get(CYCLE_THREAD, 0.0)
        other_cpu, pressure = load.stop()
        cycles_run = health_cycle(HOST) - cycle0
        client.go()
        result = client.result()
        if spy is not None:
            spy.wait()
    finally:
        server.stop()
    n, wall = result["cycles"], result["wall"]
    speed = args.motions * args.seconds / wall
    per = 1e6 / n
    rest = wall - cpu - result["cpu"]
    print(f"lockstep: {args.motions} joint position motions of {args.seconds} s, one pylibfranka "
          f"connection, {n} client cycles ({cycles_run} server cycles)")
    print(f"  simulated s per wall s        {speed:6.2f}   target ≥ {TARGETS['speed']:g}  "
          f"{verdict(speed >= TARGETS['speed'])}")
    starts = result["starts"]
    later = starts[1:] or [0.0]
    print(f"  of which motion starts (Move → first command): the first {1e3 * starts[0]:.1f} ms "
          f"(its states START_SPACING, {1e3 * START_SPACING:g} ms, apart: how the client starts "
          f"is not known yet), the others {1e3 * sum(later) / len(later):.1f} ms each (at the "
          f"client's pace); the motions' loops alone "
          f"{args.motions * args.seconds / (wall - sum(starts)):.2f} simulated s per wall s")
    # (Negative "neither": the server read for the answer while the client computed it.)
    print(f"  per client cycle, µs          wall {wall * per:6.1f} = server CPU {cpu * per:6.1f}"
          f" + client CPU {result['cpu'] * per:5.1f} + neither {rest * per:6.1f}"
          + ("  (< 0: both on a CPU at once)" if rest < 0 else ""))
    print(f"  server CPU per client cycle   {cpu * per:6.1f} µs   target ≤ "
          f"{TARGETS['cpu_cycle']:g}  {verdict(cpu * per <= TARGETS['cpu_cycle'])}"
          f"   (cycle thread {cycle_cpu * per:.1f}, the rest {(cpu - cycle_cpu) * per:.1f})")
    if cycles_run:
        print(f"  server CPU per server cycle   {1e6 * cpu / cycles_run:6.1f} µs"
              f"   (settling after each motion included)")
    print(f"  benchmarks/cycle.py, joint: {cycle_floor()}")
    print(f"  min success rate {result['min_rate']:.3f}; other processes {other_cpu:.0f} % of a "
          f"core, CPU pressure {pressure:.0f} %{idle_behaviour()}")
    if args.profile:
        print_profile(raw)


def cycle_floor() -> str:
    """benchmarks/cycle.py's total for one joint position cycle, in this run."""
    done = subprocess.run([sys.executable, str(HERE / "cycle.py"), "--mode", "joint"],
                          capture_output=True, text=True)
    lines = [line.strip() for line in done.stdout.splitlines() if "total" in line.lower()]
    return lines[0] if lines else "(no figure)"


def realtime_once(alternative: str | None, seconds: float) -> dict:
    """Server CPU % while a joint loop + Gripper run, with the client idle, and with none."""
    server = start_server(HOST, alternative)
    try:
        time.sleep(1.0)
        none = cpu_percent(server.pid, 3.0)
        client = Client(HOST, "realtime", 1, seconds)
        client.expect("ready")
        cpu0, t0 = cpu_seconds(server.pid), time.perf_counter()
        client.go()
        client.expect("done")
        control = 100 * (cpu_seconds(server.pid) - cpu0) / (time.perf_counter() - t0)
        client.go()
        client.expect("idle")
        idle = cpu_percent(server.pid, 3.0)
        rss, _ = memory_mib(server.pid)
        client.go()
        result = client.result()
    finally:
        server.stop()
    return {"control": control, "idle": idle, "none": none, "rss": rss,
            "states": result["cycles"] / result["wall"], "rate": result["min_rate"]}


def realtime(args) -> None:
    alternative = args.alternative
    runs: dict[str, list[dict]] = {"franka-sim": [], "alternative": []}
    for _ in range(args.runs):
        runs["franka-sim"].append(realtime_once(None, args.seconds))
        if alternative:
            runs["alternative"].append(realtime_once(alternative, args.seconds))
    print(f"realtime: a pylibfranka joint position loop of {args.seconds} s with a Gripper "
          f"connected, {args.runs} run(s) each, alternated{idle_behaviour()}")
    for name, results in runs.items():
        for r in results:
            print(f"  {name:<12} CPU % of a core: controlling {r['control']:5.1f}, client idle "
                  f"{r['idle']:5.1f}, no client {r['none']:5.1f}; RSS {r['rss']:5.1f} MiB; "
                  f"states/s {r['states']:6.1f}; min success rate {r['rate']:.3f}")
    if runs["alternative"]:
        ours = sum(r["control"] for r in runs["franka-sim"])
        theirs = sum(r["control"] for r in runs["alternative"])
        ratio = ours / theirs
        print(f"  CPU controlling, franka-sim / alternative  {ratio:.2f}×   target ≤ "
              f"{TARGETS['vs_alternative']:g}  {verdict(ratio <= TARGETS['vs_alternative'])}")
    rss = max(r["rss"] for r in runs["franka-sim"])
    print(f"  RSS with the control API on  {rss:.1f} MiB   target ≤ {TARGETS['rss']:g}  "
          f"{verdict(rss <= TARGETS['rss'])}")


def cxx_example(path: str) -> None:
    server = start_server(HOST, None, "--clock", "lockstep")
    try:
        cycle0, t0 = health_cycle(HOST), time.perf_counter()
        command = [path, HOST] if cannot_fake() else as_realtime([path, HOST])
        done = subprocess.run(command, input="\n", capture_output=True, text=True,
                              timeout=600)
        wall = time.perf_counter() - t0
        cycles = health_cycle(HOST) - cycle0
    finally:
        server.stop()
    speed = cycles / 1000 / wall
    print(f"C++ {Path(path).name} in lockstep: exit {done.returncode}, {cycles} cycles in "
          f"{wall:.2f} s: {speed:.2f}× real time   target ≥ {TARGETS['cxx']:g}  "
          f"{verdict(speed >= TARGETS['cxx'])}")
    if done.returncode:
        print("   " + (done.stdout + done.stderr).strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--clock", choices=["lockstep", "realtime", "both"], default="both")
    parser.add_argument("--motions", type=int, default=20)
    parser.add_argument("--seconds", type=float, default=None,
                        help="s per lockstep motion (0.5) / of the realtime loop (10)")
    parser.add_argument("--profile", action="store_true", help="sample the server with py-spy")
    parser.add_argument("--alternative", help="another simulator's command ({host}: address)")
    parser.add_argument("--runs", type=int, default=2, help="realtime runs per simulator")
    parser.add_argument("--cxx-example", action="append", default=[])
    parser.add_argument("--pingpong", action="store_true")
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} CPUs{idle_behaviour()}")
    if args.pingpong:
        subprocess.run([sys.executable, str(HERE / "pingpong.py")])
    if args.clock in ("lockstep", "both"):
        lockstep(argparse.Namespace(**{**vars(args), "seconds": args.seconds or 0.5}))
    for path in args.cxx_example:
        cxx_example(path)
    if args.clock in ("realtime", "both"):
        realtime(argparse.Namespace(**{**vars(args), "seconds": args.seconds or 10.0}))


if __name__ == "__main__":
    main()
