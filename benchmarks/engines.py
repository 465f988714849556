"""Each physics engine side by side (docs/engines.md): what a client sees and what it costs.

Per engine (`--physics mujoco`, and `genesis` where its extra is installed), on a server of its
own: spawn → "serving on"; control_loop.py's pylibfranka joint-position motion of `--seconds`
simulated seconds in lockstep (simulated s per wall s, the server's CPU per simulated s) and the same motion in
realtime (robot s per wall s: an engine slower than real time slows the robot's clock; the
success rate the robot reports);
the server's RSS (and its anonymous part) after them. Then what the genesis extra adds to an
install: its packages' size on disk, and the import and initialisation time of Genesis.

    python benchmarks/engines.py [--seconds 3] [--engines mujoco genesis]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from importlib import metadata

from _common import cpu_seconds, memory_mib
from control_loop import control
from franka_sim.testing import ServerProcess

HOST = "127.0.0.201"
START_TIMEOUT = 300.0  # s: Genesis compiles its kernels at a machine's first start


def engine_figures(engine: str, seconds: float) -> dict:
    figures = {}
    for clock in ("lockstep", "realtime"):
        server = ServerProcess(HOST, "--clock", clock, "--physics", engine)
        server.wait_ready(START_TIMEOUT)
        try:
            if clock == "lockstep":
                figures["start s"] = server.serving_after
            cpu0 = cpu_seconds(server.pid)
            run = control(HOST, seconds, "joint")  # control_loop.py's joint motion
            cpu = cpu_seconds(server.pid) - cpu0
            if clock == "lockstep":
                figures["lockstep sim s / wall s"] = run["sim"] / run["wall"]
                figures["server CPU s / sim s"] = cpu / run["sim"]
            else:
                figures["realtime robot s / wall s"] = run["sim"] / run["wall"]
                figures["realtime success rate"] = run["mean_rate"]
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
