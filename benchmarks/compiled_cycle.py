"""Would compiling the cycle's Python with Cython pay? cycle.py's figures for this tree and for
a copy of it whose hot-path modules Cython compiled, alternated.

The modules are the franka_sim modules a profile of `cycle.run` finds spending time (each
≥ 0.2 % of it, the setup's too); Cython compiles them unchanged, its annotation typing off (the
same Python objects, the same bits). The copy lives in a temporary directory and is removed after;
nothing in the tree is touched. Needs Cython (`pip install cython`) and a C compiler; it is no
dependency of franka-sim. Prints the µs per cycle (`total`, `critical`) in a tight loop and,
with `--sleep 800`, also the thread's CPU per cycle after a sleep, as the server runs.

python benchmarks/compiled_cycle.py [--mode joint|torque] [--runs 2] [--sleep 800]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import franka_sim

HERE = Path(__file__).resolve().parent
SHARE = 0.002  # of the profile's time: a module below it is left as Python


def hot_modules(mode: str) -> list[Path]:
    """The franka_sim source files a profile of cycle.py's run spends time in (relative)."""
    from cycle import run

    package = Path(franka_sim.__file__).resolve().parent
    profile = cProfile.Profile()
    profile.runcall(run, mode, 2000)
    by_file: dict[str, float] = {}
    for (filename, _, _), (_, _, tottime, _, _) in pstats.Stats(profile).stats.items():
        by_file[filename] = by_file.get(filename, 0.0) + tottime
    total = sum(by_file.values())
    return sorted(Path(name).resolve().relative_to(package) for name, spent in by_file.items()
                  if name.startswith(str(package)) and name.endswith(".py")
                  and spent >= SHARE * total and not name.endswith("__init__.py"))


def compiled_copy(modules: list[Path], into: Path) -> Path:
    """A copy of the source tree with `modules` compiled in place; its `src` (for PYTHONPATH)."""
    package = Path(franka_sim.__file__).resolve().parent
    src = into / "src"
    shutil.copytree(package, src / "franka_sim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    checkout_urdf = package.parents[1] / "urdf"  # a source checkout's URDFs (description/urdf.py)
    if checkout_urdf.is_dir():
        shutil.copytree(checkout_urdf, into / "urdf")
    build = subprocess.run([sys.executable, "-m", "Cython.Build.Cythonize", "-i", "-3", "-q",
                            "-X", "annotation_typing=False", "-j", str(os.cpu_count() or 1),
                            *map(str, modules)],
                           cwd=src / "franka_sim", capture_output=True, text=True)
    if build.returncode:
        sys.exit(f"Cython failed:\n{build.stdout}{build.stderr}")
    return src


def cycle_figures(mode: str, sleep: float, pythonpath: str | None) -> dict[str, float]:
    """cycle.py's total, critical (and cpu) µs, run in a process of its own."""
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    out = subprocess.run([sys.executable, "cycle.py", "--mode", mode, "--sleep", str(sleep)],
                         cwd=HERE, env=env, check=True, capture_output=True, text=True).stdout
    return {name: float(value) for name, value in
            re.findall(r"^\s+(total|critical|cpu)\s+([\d.]+)", out, re.MULTILINE)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mode", choices=("joint", "torque"), default="joint")
    parser.add_argument("--runs", type=int, default=2)
    parser.add_argument("--sleep", type=float, default=0.0, metavar="US")
    args = parser.parse_args()
    try:
        import Cython
    except ImportError:
        sys.exit("needs Cython: pip install cython")
    modules = hot_modules(args.mode)
    print(f"Cython {Cython.__version__}: compiling {len(modules)} modules: "
          + " ".join(str(m) for m in modules))
    with tempfile.TemporaryDirectory(prefix="franka-sim-cython-") as tmp:
        compiled = str(compiled_copy(modules, Path(tmp)))
        runs: dict[str, list[dict[str, float]]] = {"python": [], "cython": []}
        for _ in range(args.runs):  # alternated: the machine's drift falls on both
            runs["python"].append(cycle_figures(args.mode, args.sleep, None))
            runs["cython"].append(cycle_figures(args.mode, args.sleep, compiled))
    loop = f"after a {args.sleep:g} µs sleep" if args.sleep else "a tight loop"
    print(f"µs per {args.mode} cycle, {loop}, {args.runs} runs each (lowest–highest)")
    for name in runs["python"][0]:
        cells = [f"{tree} {min(r[name] for r in rs):.1f}–{max(r[name] for r in rs):.1f}"
                 for tree, rs in runs.items()]
        print(f"  {name:8s} " + "   ".join(cells))


if __name__ == "__main__":
    main()
