"""A user's test suite of short motions through the `franka_sim` fixture, end to end.

Writes a throw-away test project into a temporary directory: one module of N tests (default
50), each 0.5 s of motion after the fixture's reset, in turn a joint position, a Cartesian pose
and a torque motion, each through a new pylibfranka.Robot as a user's test makes one. Runs
pytest on it in a subprocess, serially or on xdist workers (`--workers 2`), and prints the wall
seconds per test and the simulated seconds of motion per wall second, end to end: from spawning
pytest to its exit, with its start, collection, the simulators' starts and every reset.
Target on this 2-core machine: ≥ 5× real time end to end (lockstep clock).

The per-test split comes from the project's conftest (pytest's phase durations) and from the
tests themselves: setup is the fixture (a reset; a worker's first test starts its simulator),
call is the test (connect, the motion's start up to its first state, the motion's loop).

python benchmarks/suite.py [--tests 50] [--seconds 0.5] [--workers 0|2] [--clock lockstep]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from importlib.metadata import entry_points
from pathlib import Path

from _common import Load, idle_behaviour, verdict

TARGET = 5.0  # simulated s per wall s, end to end

CONFTEST = '''
import json
import os

import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """One JSON line per test phase, written by the process that ran the test."""
    outcome = yield
    report = outcome.get_result()
    with open(os.environ["SUITE_RECORD"], "a") as out:
        out.write(json.dumps({"test": item.name, "when": report.when, "outcome": report.outcome,
                              "seconds": report.duration,
                              "worker": os.environ.get("PYTEST_XDIST_WORKER", "-"),
                              **dict(report.user_properties)}) + "\\n")
'''

TESTS = '''
import math
import os
import time

import numpy as np
import pylibfranka
import pytest

SECONDS = float(os.environ["SUITE_SECONDS"])
JI = pylibfranka.ControllerMode.JointImpedance
K = np.array([600.0, 600.0, 600.0, 600.0, 250.0, 150.0, 50.0])
D = np.array([50.0, 50.0, 50.0, 20.0, 20.0, 20.0, 10.0])


def start(robot, kind):
    if kind == "joint":
        return robot.start_joint_position_control(JI)
    if kind == "cartesian":
        return robot.start_cartesian_pose_control(JI)
    return robot.start_torque_control()


def command(kind, first, state, n, bump):
    """Out and back: joint n % 7 by 0.1 rad, the hand 5 cm along x, or a torque set-point."""
    if kind == "joint":
        q = first.copy()
        q[n % 7] += 0.1 * bump
        return pylibfranka.JointPositions(q.tolist())
    if kind == "cartesian":
        pose = first.copy()
        pose[12] += 0.05 * bump
        return pylibfranka.CartesianPose(pose.tolist())
    q_d = first.copy()
    q_d[n % 7] += 0.1 * bump
    tau = K * (q_d - np.array(state.q)) - D * np.array(state.dq)
    return pylibfranka.Torques(tau.tolist())


@pytest.mark.parametrize("n", range(int(os.environ["SUITE_TESTS"])))
def test_short_motion(franka_sim, n, record_property):
    kind = ("joint", "cartesian", "torque")[n % 3]
    t0 = time.perf_counter()
    robot = pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore)
    t1 = time.perf_counter()
    control = start(robot, kind)
    state, _ = control.readOnce()
    t2 = time.perf_counter()
    first = np.array({"joint": state.q_d, "cartesian": state.O_T_EE_c, "torque": state.q}[kind])
    sim0, t = state.time.to_sec(), 0.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        bump = 0.5 * (1 - math.cos(2 * math.pi * min(t / SECONDS, 1.0)))
        out = command(kind, first, state, n, bump)
        out.motion_finished = t >= SECONDS
        control.writeOnce(out)
        if out.motion_finished:
            break
    record_property("kind", kind)
    record_property("connect", t1 - t0)
    record_property("start", t2 - t1)
    record_property("loop", time.perf_counter() - t2)
    record_property("simulated", state.time.to_sec() - sim0)
'''


def run_project(tests: int, seconds: float, workers: int, clock: str) -> dict:
    """Write the project, run pytest on it; the wall time end to end and the phase records."""
    with tempfile.TemporaryDirectory(prefix="franka-sim-suite-") as tmp:
        project = Path(tmp) / "project"
        project.mkdir()
        (project / "conftest.py").write_text(CONFTEST)
        (project / "test_suite.py").write_text(TESTS)
        record = Path(tmp) / "record.jsonl"
        env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
        env.update(SUITE_RECORD=str(record), SUITE_TESTS=str(tests), SUITE_SECONDS=str(seconds))
        # Installed, the package's pytest11 entry point loads the plugin; else load it by name.
        installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
        command = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q",
                   "--franka-sim-clock", clock]
        command += [] if installed else ["-p", "franka_sim.pytest_plugin"]
        command += ["-n", str(workers)] if workers else []
        load = Load(exclude=set())  # pytest and its servers exit inside the window: not counted
        t0 = time.perf_counter()
        done = subprocess.run(command, cwd=project, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        other_cpu, pressure = load.stop()
        records = [json.loads(line) for line in record.read_text().splitlines()] \
            if record.exists() else []
    return {"wall": wall, "records": records, "code": done.returncode,
            "output": done.stdout + done.stderr, "other_cpu": other_cpu, "pressure": pressure}


def _mean(values: list[float]) -> float:
    return statistics.fmean(values) if values else float("nan")


def report(result: dict, tests: int, seconds: float, workers: int, clock: str) -> None:
    by_test: dict[str, dict] = {}
    for r in result["records"]:
        entry = by_test.setdefault(r["test"], {"worker": r["worker"]})
        entry[r["when"]] = r["seconds"]
        if r["when"] == "call":
            entry.update({k: r[k] for k in ("connect", "start", "loop", "simulated", "kind")
                          if k in r})
            entry["passed"] = r["outcome"] == "passed"
    passed = [e for e in by_test.values() if e.get("passed")]
    per_test = [e.get("setup", 0) + e.get("call", 0) + e.get("teardown", 0)
                for e in by_test.values()]
    # A worker's first test starts its simulator in its setup; the others reset it.
    first = {}
    for name, e in by_test.items():  # records arrive in each worker's order
        first.setdefault(e["worker"], name)
    starts = [by_test[name]["setup"] for name in first.values() if "setup" in by_test[name]]
    resets = [e["setup"] for name, e in by_test.items()
              if name not in first.values() and "setup" in e]
    simulated = sum(e.get("simulated", 0.0) for e in passed)
    wall = result["wall"]
    speed = simulated / wall
    motion_wall = sum(e["start"] + e["loop"] for e in passed)
    mode = f"{workers} xdist workers" if workers else "serial"
    print(f"franka-sim test suite: {tests} tests of {seconds:g} s of motion (joint position, "
          f"Cartesian pose, torque in turn), {clock} clock, {mode}")
    print(f"  tests passed                                {len(passed)} / {tests}")
    if result["code"] != 0 or len(passed) < tests:
        print("  pytest's output (tail):\n    "
              + "\n    ".join(result["output"].strip().splitlines()[-15:]))
    print(f"  wall s end to end (pytest spawn → exit)     {wall:.2f}   "
          f"{wall / tests:.3f} per test")
    print(f"  wall s per test (setup + call + teardown)   mean {_mean(per_test):.3f}   "
          f"median {statistics.median(per_test) if per_test else float('nan'):.3f}   "
          f"max {max(per_test, default=float('nan')):.3f}")
    print(f"    setup: simulator start (a worker's first) {_mean(starts):.3f}   "
          f"({len(starts)} started)")
    print(f"    setup: reset (the others)                 mean {_mean(resets):.4f}")
    print(f"    call: connect (pylibfranka.Robot)         mean "
          f"{_mean([e['connect'] for e in passed]):.4f}")
    print(f"    call: motion start → first state          mean "
          f"{_mean([e['start'] for e in passed]):.4f}")
    for kind in ("joint", "cartesian", "torque"):
        loops = [e["loop"] for e in passed if e.get("kind") == kind]
        label = f"    call: {seconds:g} s {kind} motion loop"
        print(f"{label:<46}mean {_mean(loops):.4f}")
    print(f"    teardown                                  mean "
          f"{_mean([e.get('teardown', 0) for e in by_test.values()]):.4f}")
    print(f"  simulated s of motion                       {simulated:.2f}")
    print(f"  simulated s per wall s, motions alone       "
          f"{simulated / motion_wall if motion_wall else float('nan'):.2f}   "
          "(start + loop, summed over tests)")
    print(f"  simulated s per wall s, end to end          {speed:.2f}   target ≥ {TARGET:g}  "
          f"{verdict(speed >= TARGET)}")
    print(f"  machine: {os.cpu_count()} CPUs; other processes used {result['other_cpu']:.0f} % "
          f"of a core (this run's pytest and simulators excluded), tasks waited for a CPU "
          f"{result['pressure']:.0f} % of the time{idle_behaviour()}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tests", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=0.5, help="simulated s of motion each")
    parser.add_argument("--workers", type=int, default=0, help="xdist workers (0: serial)")
    parser.add_argument("--clock", choices=["lockstep", "realtime"], default="lockstep")
    args = parser.parse_args()
    result = run_project(args.tests, args.seconds, args.workers, args.clock)
    report(result, args.tests, args.seconds, args.workers, args.clock)


if __name__ == "__main__":
    main()
