"""Each physics engine side by side (docs/engines.md): what a client sees and what it costs.

Per engine (`--physics mujoco`, and `genesis` where its extra is installed), on a server of its
own: spawn → "serving on"; a pylibfranka joint-position motion of `--seconds` simulated seconds
in lockstep (simulated s per wall s, the server's CPU per simulated s) and the same motion in
realtime (robot s per wall s: an engine slower than real time slows the robot's clock; the
success rate the robot reports);
the server's RSS (and its anonymous part) after them. Then what the genesis extra adds to an
install: its packages' size on disk, and the import and initialisation time of Genesis.

    python benchmarks/engines.py [--seconds 3] [--engines mujoco genesis]
"""

from __future__ import annotations

import argparse
import gc
import math
import subprocess
import sys
import time
from importlib import metadata

import numpy as np

from _common import cpu_seconds, memory_mib
from franka_sim.testing import ServerProcess

HOST = "127.0.0.201"
START_TIMEOUT = 300.0  # s: Genesis compiles its kernels at a machine's first start


def motion(host: str, seconds: float) -> tuple[float, float]:
    """(wall s, success rate) of a cosine joint motion of `seconds` simulated seconds (its
    robot time: the states' own `time`)."""
    import pylibfranka

    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0, t, rates = np.array(state.q_d), 0.0, []
    offset = np.array([0.3, 0.2, -0.2, 0.3, 0.2, -0.2, 0.3])
    start = time.perf_counter()
    while True:
        state, period = control.readOnce()
        rates.append(state.control_command_success_rate)
        t += period.to_sec()
        s = 0.5 * (1 - math.cos(2 * math.pi * min(t / seconds, 1.0)))  # there and back
        command = pylibfranka.JointPositions((q0 + s * offset).tolist())
        command.motion_finished = t >= seconds
        control.writeOnce(command)
        if command.motion_finished:
            break
    wall = time.perf_counter() - start
    del control, robot
    gc.collect()
    return wall, float(np.mean(rates[100:])) if len(rates) > 100 else float("nan")


def engine_figures(engine: str, seconds: float) -> dict:
    figures = {}
    for clock in ("lockstep", "realtime"):
        server = ServerProcess(HOST, "--clock", clock, "--physics", engine)
        server.wait_ready(START_TIMEOUT)
        try:
            if clock == "lockstep":
                figures["start s"] = server.serving_after
            cpu0 = cpu_seconds(server.pid)
            wall, success = motion(HOST, seconds)
            cpu = cpu_seconds(server.pid) - cpu0
            if clock == "lockstep":
                figures["lockstep sim s / wall s"] = seconds / wall
                figures["server CPU s / sim s"] = cpu / seconds
            else:
                figures["realtime robot s / wall s"] = seconds / wall
                figures["realtime success rate"] = success
                figures["RSS MiB (anonymous)"] = memory_mib(server.pid)
        finally:
            server.stop()
    return figures


def _closure(requirements: list[str]) -> set[str]:
    """The installed distributions `requirements` pull in (names, normalised)."""
    from packaging.requirements import Requirement

    seen, todo = set(), list(requirements)
    while todo:
        req = Requirement(todo.pop())
        name = req.name.lower().replace("_", "-")
        if name in seen or (req.marker is not None and not req.marker.evaluate({"extra": ""})):
            continue
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        seen.add(name)
        todo.extend(dist.requires or [])
    return seen


def extra_figures() -> dict:
    """What `pip install 'franka-sim[genesis]'` adds beyond the core install."""
    core = _closure(["franka-sim"])
    extra = _closure(["genesis-world", "torch"]) - core
    size = 0
    for name in extra:
        for file in metadata.distribution(name).files or ():
            try:
                size += file.locate().stat().st_size
            except OSError:
                pass
    timed = ("import time; t = time.perf_counter(); import genesis as gs; "
             "i = time.perf_counter(); gs.init(backend=gs.cpu, precision='64', "
             "logging_level='error'); print(i - t, time.perf_counter() - i)")
    out = subprocess.run([sys.executable, "-c", timed], capture_output=True, text=True).stdout
    imported, initialised = (float(v) for v in out.split()[-2:])
    return {"packages": len(extra), "size MB": size / 1e6, "import s": imported,
            "gs.init s": initialised}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seconds", type=float, default=3.0, help="simulated s per motion (3)")
    ap.add_argument("--engines", nargs="+", default=["mujoco", "genesis"])
    args = ap.parse_args()
    from franka_sim.physics.engine_choice import engine_missing

    for engine in args.engines:
        if missing := engine_missing(engine):
            print(f"{engine}: skipped ({missing})")
            continue
        figures = engine_figures(engine, args.seconds)
        rss, anon = figures.pop("RSS MiB (anonymous)")
        print(f"{engine}: " + ", ".join(f"{k} {v:.3f}" for k, v in figures.items())
              + f", RSS {rss:.0f} MiB ({anon:.0f} anonymous)")
    if "genesis" in args.engines and engine_missing("genesis") is None:
        extra = extra_figures()
        print(f"genesis extra: {extra['packages']} packages beyond the core, "
              f"{extra['size MB']:.0f} MB on disk; import genesis {extra['import s']:.1f} s, "
              f"gs.init {extra['gs.init s']:.1f} s")


if __name__ == "__main__":
    main()
