"""Prebuilt model libraries for older libfranka clients, into a directory that
`FRANKA_SIM_MODEL_LIBRARIES` then names (docs/clients.md):

    python -m franka_sim.model_library DIR [--robot fr3 --robot fer] [--urdf FILE]
                                           [--target x86_64-linux --target aarch64-linux]
                                           [--cc "COMMAND"]

Without --robot or --urdf: every packaged robot's (fr3, fer). The compiler: --cc, else
`python -m ziglang cc` where the ziglang package is installed (it builds for each --target:
x86_64-linux, aarch64-linux; default both), else the system's (`$CC`, `cc`), which builds for
this machine alone. Prints each file it wrote; a bad argument or a failed compile is one line
on stderr and exit status 1 or 2.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from franka_sim.config import ROBOTS
from franka_sim.description.urdf import (DescriptionError, default_urdf_text,
                                         load_arm_description)
from franka_sim.model_library.build import (ZIG_TARGETS, CompileError, is_zig, parse_target,
                                            prebuild, system_compiler, this_machine,
                                            zig_compiler)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m franka_sim.model_library",
                                     description=" ".join(__doc__.split("\n\n")[0].split()))
    parser.add_argument("directory", type=Path)
    parser.add_argument("--robot", action="append", choices=ROBOTS, default=[],
                        help="a packaged robot's description (repeatable)")
    parser.add_argument("--urdf", action="append", type=Path, default=[],
                        help="an arm's URDF, as `serve --urdf` takes it (repeatable)")
    parser.add_argument("--target", action="append", default=[],
                        help="x86_64-linux or aarch64-linux (repeatable; a zig compiler only)")
    parser.add_argument("--cc", help="the compiler command, e.g. \"python -m ziglang cc\"")
    args = parser.parse_args(argv)
    try:
        targets = [parse_target(t) for t in args.target]
    except ValueError as exc:
        parser.error(str(exc))
    compiler = shlex.split(args.cc) if args.cc else (
        zig_compiler() or system_compiler() or ["cc"])
    if not targets:
        targets = list(ZIG_TARGETS) if is_zig(compiler) else [this_machine()]
    descriptions = {}
    try:
        for robot in args.robot or ([] if args.urdf else ROBOTS):
            descriptions[robot] = load_arm_description(default_urdf_text(robot))
        for urdf in args.urdf:
            descriptions[str(urdf)] = load_arm_description(urdf.read_text())
    except (OSError, DescriptionError) as exc:
        print(f"model libraries: {exc}", file=sys.stderr)
        return 1
    try:
        written = prebuild(args.directory, descriptions, targets, compiler)
    except (CompileError, ValueError, OSError) as exc:
        print(f"model libraries: {exc}", file=sys.stderr)
        return 1
    for path in written:
        print(f"{path} ({path.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
