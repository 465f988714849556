"""A model library for the machine a client runs on, once per arm description and target, kept.

A LoadModelLibrary names the client's architecture and system (libfranka's names); the library
for them is, in this order:
1. prebuilt: a file in the directory `$FRANKA_SIM_MODEL_LIBRARIES` names (the image sets it
   and carries the packaged robots' libraries for Linux x86_64 and aarch64; `python -m
   franka_sim.model_library DIR` makes such a directory);
2. kept: one built before, in the user's cache (`$XDG_CACHE_HOME/franka-sim`, else
   `~/.cache/franka-sim`);
3. built now: for this machine with the system's C compiler (`$CC` where it names one that is
   there, else `cc`, else `gcc`); where the `ziglang` package is installed, with `python -m
   ziglang cc` for the Linux targets of any machine (x86_64, aarch64), this one too when it
   has no compiler. What is built is kept in the cache.
Each file is named by a hash of the library's C source and its target
(`model-library-HASH-ARCH-SYSTEM.so`, e.g. `...-x86_64-linux.so`), so a library is found for
the very description it was made from. A client whose library none of these gives is answered
without one (the robot's kError), with one log line saying why.
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from franka_sim.description.urdf import ArmDescription
from franka_sim.model_library.source import c_source

log = logging.getLogger(__name__)

PREBUILT_VARIABLE = "FRANKA_SIM_MODEL_LIBRARIES"

# libfranka's names for this machine (LoadModelLibrary's Architecture and System).
_ARCHITECTURES = {"x86_64": "kX64", "amd64": "kX64", "aarch64": "kARM64", "arm64": "kARM64",
                  "i686": "kX86", "armv7l": "kARM"}
_SYSTEMS = {"Linux": "kLinux", "Windows": "kWindows"}
# A target's part of a library's file name, for each name libfranka has.
_ARCHITECTURE_NAMES = {"kX64": "x86_64", "kX86": "x86", "kARM64": "aarch64", "kARM": "arm"}
_SYSTEM_NAMES = {"kLinux": "linux", "kWindows": "windows"}
# What `zig cc -target` builds for (the glibc Linux of the two 64-bit architectures).
ZIG_TARGETS = {("kX64", "kLinux"): "x86_64-linux-gnu", ("kARM64", "kLinux"): "aarch64-linux-gnu"}
_FLAGS = ["-O2", "-shared", "-fPIC"]
_SAID_NO_DIRECTORY: set[Path] = set()  # each said once a process


def this_machine() -> tuple[str | None, str | None]:
    """(architecture, system) as libfranka names them; None where it has no name for it."""
    return _ARCHITECTURES.get(platform.machine().lower()), _SYSTEMS.get(platform.system())


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "franka-sim"


def source_hash(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]


def library_name(source: str, target: tuple[str, str]) -> str:
    """The file name of `source`'s library for `target` (architecture, system), or ValueError
    for a target libfranka has no name for."""
    architecture, system = target
    if architecture not in _ARCHITECTURE_NAMES or system not in _SYSTEM_NAMES:
        raise ValueError(f"no such target: {architecture}/{system}")
    return f"model-library-{source_hash(source)}-{target_text(target)}.so"


def target_text(target: tuple[str, str]) -> str:
    """'x86_64-linux' for ('kX64', 'kLinux'); libfranka's names where it has no such name."""
    architecture, system = target
    if architecture in _ARCHITECTURE_NAMES and system in _SYSTEM_NAMES:
        return f"{_ARCHITECTURE_NAMES[architecture]}-{_SYSTEM_NAMES[system]}"
    return f"{architecture}/{system}"


def parse_target(text: str) -> tuple[str, str]:
    """'x86_64-linux' (a file name's) or 'kX64/kLinux' (libfranka's) as (architecture,
    system); ValueError naming the choices otherwise."""
    for architecture, a in _ARCHITECTURE_NAMES.items():
        for system, s in _SYSTEM_NAMES.items():
            if text in (f"{a}-{s}", f"{architecture}/{system}"):
                return architecture, system
    choices = ", ".join(f"{_ARCHITECTURE_NAMES[a]}-{_SYSTEM_NAMES[s]}" for a, s in ZIG_TARGETS)
    raise ValueError(f"no such target {text!r} (e.g. {choices})")


def prebuilt_dir() -> Path | None:
    """The directory `$FRANKA_SIM_MODEL_LIBRARIES` names (None: unset or empty)."""
    value = os.environ.get(PREBUILT_VARIABLE)
    return Path(value) if value else None


def system_compiler() -> list[str] | None:
    """This machine's C compiler: $CC if it names one that is there, else cc or gcc; None."""
    if cc := os.environ.get("CC"):
        command = shlex.split(cc)
        if command and shutil.which(command[0]):
            return command
    found = shutil.which("cc") or shutil.which("gcc")
    return [found] if found else None


def zig_compiler() -> list[str] | None:
    """`python -m ziglang cc` where the ziglang package is installed, else None."""
    if importlib.util.find_spec("ziglang") is None:
        return None
    return [sys.executable, "-P", "-m", "ziglang", "cc"]


class CompileError(Exception):
    """The compiler could not be run or failed: its last line."""


def compile_library(source: str, compiler: list[str], zig_target: str | None = None) -> bytes:
    """`source` compiled by `compiler` (argv; `zig_target`: with `-target` for it) into a shared
    library's bytes, or CompileError."""
    target = ["-target", zig_target] if zig_target else []
    with tempfile.TemporaryDirectory() as work:
        c_file, so_file = Path(work, "model.c"), Path(work, "model.so")
        c_file.write_text(source)
        try:
            done = subprocess.run([*compiler, *target, *_FLAGS, "-o", str(so_file), str(c_file),
                                   "-lm"], capture_output=True, text=True,
                                  stdin=subprocess.DEVNULL)
        except OSError as exc:  # no such compiler, not executable
            raise CompileError(str(exc)) from None
        if done.returncode != 0:
            lines = done.stderr.strip().splitlines()
            raise CompileError(lines[-1] if lines else f"exit status {done.returncode}")
        return so_file.read_bytes()


class ModelLibrary:
    """The model library of one arm description, per target: prebuilt, kept, or built on first
    use and kept (the module's docstring)."""

    def __init__(self, description: ArmDescription) -> None:
        self.description = description
        self._source: str | None = None
        self._made: dict[tuple[str, str], bytes] = {}

    @property
    def source(self) -> str:
        if self._source is None:
            self._source = c_source(self.description)
        return self._source

    def for_client(self, request) -> bytes | None:
        """The library for a LoadModelLibrary request (its `architecture` and `system`), or
        None (logged) when none can be had for it."""
        wanted = (str(request.architecture), str(request.system))
        if wanted not in self._made:  # a miss is looked for again (and said again) next time
            found = self._find(wanted)
            if found is None:
                return None
            self._made[wanted] = found
        return self._made[wanted]

    def _find(self, wanted: tuple[str, str]) -> bytes | None:
        try:
            name = library_name(self.source, wanted)
        except ValueError:
            log.warning("model library for %s/%s asked for: no such target: answered kError",
                        *wanted)
            return None
        prebuilt = prebuilt_dir()
        if prebuilt is not None:
            if (prebuilt / name).is_file():
                data = (prebuilt / name).read_bytes()
                log.info("model library for %s (%s/%s) prebuilt in %s (%d bytes)",
                         self.description.name, *wanted, prebuilt, len(data))
                return data
            if not prebuilt.is_dir() and prebuilt not in _SAID_NO_DIRECTORY:
                _SAID_NO_DIRECTORY.add(prebuilt)
                log.warning("%s=%s is no directory: no prebuilt model libraries",
                            PREBUILT_VARIABLE, prebuilt)
        kept = cache_dir() / name
        if kept.is_file():
            return kept.read_bytes()
        data = self._build(wanted)
        if data is not None:
            self._keep(kept, data)
        return data

    def _build(self, wanted: tuple[str, str]) -> bytes | None:
        here = this_machine()
        system_cc = system_compiler()
        zig = zig_compiler()
        if wanted == here and system_cc is not None:
            compiler, zig_target = system_cc, None
        elif wanted in ZIG_TARGETS and zig is not None:
            compiler, zig_target = zig, ZIG_TARGETS[wanted]
        elif wanted == here:
            log.warning("no C compiler (cc, or $CC) to build the model library older "
                        "libfranka clients load, and none prebuilt for %s/%s (%s): "
                        "LoadModelLibrary answered kError", *wanted, self._where())
            return None
        else:
            log.warning("model library for %s/%s asked for: none prebuilt (%s), and this "
                        "machine makes one for %s/%s only: answered kError", *wanted,
                        self._where(), *here)
            return None
        try:
            data = compile_library(self.source, compiler, zig_target)
        except CompileError as exc:
            log.warning("the model library did not compile (%s): %s: LoadModelLibrary "
                        "answered kError", shlex.join(compiler), exc)
            return None
        log.info("model library for %s (%s/%s) built (%d bytes)", self.description.name,
                 *wanted, len(data))
        return data

    @staticmethod
    def _where() -> str:
        prebuilt = prebuilt_dir()
        return f"{PREBUILT_VARIABLE} unset" if prebuilt is None else f"in {prebuilt}"

    @staticmethod
    def _keep(path: Path, data: bytes) -> None:
        """Kept for the next time; a cache that cannot be written only costs a rebuild."""
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            kept = path.with_suffix(f".{os.getpid()}.tmp")
            kept.write_bytes(data)
            kept.replace(path)
        except OSError as exc:
            log.info("model library not kept in %s: %s", path.parent, exc)


def prebuild(directory: Path, descriptions: dict[str, ArmDescription],
             targets: list[tuple[str, str]], compiler: list[str]) -> list[Path]:
    """Each description's library for each target, compiled by `compiler` (a zig cc: given
    `-target`; any other compiler builds for its own machine, so one target only), into
    `directory` under the names ModelLibrary looks for: the files written, or CompileError
    (ValueError: a target `compiler` cannot build for)."""
    zig = is_zig(compiler)
    for target in targets:
        if target not in ZIG_TARGETS if zig else target != this_machine():
            raise ValueError(f"{shlex.join(compiler)} builds no library for "
                             f"{target_text(target)}: only a zig cc builds for another "
                             f"machine (pip install ziglang; --cc 'python -m ziglang cc')")
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for label, description in descriptions.items():
        source = c_source(description)
        for target in targets:
            zig_target = ZIG_TARGETS[target] if zig else None
            try:
                data = compile_library(source, compiler, zig_target)
            except CompileError as exc:
                raise CompileError(f"{label} for {target_text(target)}: {exc}") from None
            path = directory / library_name(source, target)
            path.write_bytes(data)
            written.append(path)
    return written


def is_zig(compiler: list[str]) -> bool:
    """The compiler command is zig's (`zig cc`, `python -m ziglang cc`): it cross-compiles."""
    return any(Path(part).name.startswith("zig") for part in compiler)
