"""Rewrite the committed recordings of older libfranka's C++ examples
(tests/data/older_libfranka/<version>/<example>.mcap) that
tests/recording/test_libfranka_cpp_recordings.py replays where no libfranka build exists.

    FRANKA_SIM_LIBFRANKA_BUILDS=BUILD[:BUILD...] python tests/support/record_older_libfranka.py

Each BUILD is a build directory of tests/support/build_older_libfranka.sh (libfranka's sources
are the user's to supply); run as root (libfranka_cpp.py says why). A build with
`vacuum_object` has it recorded too, served `--tool vacuum`. Each example runs once on
a fresh simulator in lockstep with `--record`. The long ones are stopped after CUTS cycles so
the files stay small (~0.5 kB per cycle of motion); the rest run to their end. Run it again
when the recording format or the simulator's behaviour changes (replay then no longer says
identical).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

# What pytest's `pythonpath` gives the tests: tests/ (support) and examples/ (pick_and_place).
sys.path[:0] = [str(Path(__file__).resolve().parents[n] / d) for n, d in ((1, ""), (2, "examples"))]

from franka_sim.testing import running_sim  # noqa: E402
from support import libfranka_cpp as cpp  # noqa: E402

REPOSITORY = Path(__file__).resolve().parents[2]
DATA = REPOSITORY / "tests" / "data" / "older_libfranka"
# The default scene named from the repository's root (the server runs there), so the files
# hold no path of the machine that recorded them.
SCENE = "src/franka_sim/scenes/default.xml"
# Cycles after the arm is first seen moving at which the example is stopped; the others run
# whole.
CUTS = {"communication_test": 400, "generate_joint_position_motion": 350,
        "generate_cartesian_pose_motion": 350, "cartesian_impedance_control": 400}


def record(build: cpp.Build, name: str) -> Path:
    path = DATA / build.version / f"{name}.mcap"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.unlink(missing_ok=True)
    with running_sim("--clock", "lockstep", "--scene", SCENE, "--record", str(path),
                     *cpp.KNOWN[name].serve) as sim:
        run = cpp.run(build, name, sim.host, cycles=CUTS.get(name))
    if run.returncode != 0 and not run.stopped:
        raise SystemExit(f"{name} of libfranka {build.version} failed:\n{run.stdout}")
    return path


def main() -> None:
    reason = cpp.cannot_run()
    if reason:
        raise SystemExit(reason)
    os.chdir(REPOSITORY)
    for build in cpp.builds():
        pump = ["vacuum_object"] if build.example("vacuum_object").exists() else []
        for name in [*cpp.EXAMPLES, *pump]:
            path = record(build, name)
            print(f"{path.relative_to(DATA)}: {path.stat().st_size // 1024} KiB")


if __name__ == "__main__":
    main()
