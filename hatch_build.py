"""Build hook: compile franka_sim.kernels._compiled (the C files of src/franka_sim/kernels/c/,
the Python headers, no numpy headers) into the wheel, where a C compiler and the headers are
there.

Without them the wheel stays pure Python and franka_sim.kernels runs its numpy reference, which
gives the same bits, only slower (docs/benchmarks.md): `pip install` never needs a compiler.
Why the module was not built is a warning of the build (pip shows it with -v); a server on the
reference says so in its log at start.
The compiler is $CC (e.g. CC="python -m ziglang cc"), else the one Python was built with.
FRANKA_SIM_KERNELS=numpy skips the compilation. An editable install compiles in place, beside
the source (src/franka_sim/kernels/), as the editable package is imported from there.
The hook also puts the arm descriptions (urdf/) into a wheel, whether or not it compiles.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from hatchling.builders.hooks.plugin.interface import BuildHookInterface

SOURCES = Path("src/franka_sim/kernels/c")  # its *.c files make the one module
MODULE = "_compiled"
PACKAGE_DIR = "franka_sim/kernels"  # where the module goes in the wheel
# -ffp-contract=off: no fused multiply-add, so each operation rounds as numpy's does.
FLAGS = ["-O2", "-ffp-contract=off", "-fPIC", "-shared", "-fvisibility=hidden"]


def compiler() -> list[str] | None:
    """The C compiler command, or None if there is none."""
    command = shlex.split(os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc")
    if not command:
        return None
    if command[0] == sys.executable or Path(command[0]).name.startswith("python"):
        return command  # e.g. `python -m ziglang cc`
    return command if shutil.which(command[0]) else None


def compile_kernels(sources: Path, target: Path) -> str | None:
    """Compile the C files in `sources` into the extension module `target`; the reason if it
    could not."""
    if os.environ.get("FRANKA_SIM_KERNELS", "").lower() == "numpy":
        return "FRANKA_SIM_KERNELS=numpy"
    cc = compiler()
    if cc is None:
        return "no C compiler (set CC)"
    include = sysconfig.get_paths()["include"]
    if not Path(include, "Python.h").is_file():
        return f"no Python headers in {include}"
    extra = ["-undefined", "dynamic_lookup"] if sys.platform == "darwin" else []
    target.parent.mkdir(parents=True, exist_ok=True)
    files = [str(path) for path in sorted(sources.glob("*.c"))]
    command = [*cc, *FLAGS, *extra, f"-I{include}", *files, "-o", str(target)]
    try:
        run = subprocess.run(command, capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"{shlex.join(command)}: {error}"
    if run.returncode != 0:
        return f"{shlex.join(command)} failed:\n{run.stderr.strip()}"
    return None


class CustomBuildHook(BuildHookInterface):
    def initialize(self, version: str, build_data: dict) -> None:
        if self.target_name != "wheel":
            return
        root = Path(self.root)
        if version != "editable":
            # Beside the modules; an editable install reads them from the checkout.
            build_data["force_include"][str(root / "urdf")] = "franka_sim/urdf"
        name = MODULE + sysconfig.get_config_var("EXT_SUFFIX")
        if version == "editable":
            target = root / SOURCES.parent / name
        else:
            target = root / "build" / "kernels" / name
        problem = compile_kernels(root / SOURCES, target)
        if problem is not None:
            self.app.display_warning(
                f"franka-sim: the compiled kernels are not built ({problem}); the numpy "
                "reference runs instead (the same results, a slower cycle)")
            return
        build_data["pure_python"] = False
        build_data["infer_tag"] = True
        if version != "editable":
            build_data["force_include"][str(target)] = f"{PACKAGE_DIR}/{name}"
