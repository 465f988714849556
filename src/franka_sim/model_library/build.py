"""A model library compiled for this machine, once per arm description, and kept.

The library is built with the system's C compiler (`$CC`, else `cc`) the first time a client
asks for it and kept in the user's cache (`$XDG_CACHE_HOME/franka-sim`, else
`~/.cache/franka-sim`), named by a hash of its source, so a second server, run or test takes it
from there. It is built for the machine the simulator runs on: a client asking for another
architecture or system (libfranka says which) is answered without one, as is any client when no
compiler is at hand; each says why in one log line.
"""

from __future__ import annotations

import hashlib
import logging
import os
import platform
import shutil
import subprocess
import tempfile
from pathlib import Path

from franka_sim.description.urdf import ArmDescription
from franka_sim.model_library.source import c_source

log = logging.getLogger(__name__)

# libfranka's names for this machine (LoadModelLibrary's Architecture and System).
_ARCHITECTURES = {"x86_64": "kX64", "amd64": "kX64", "aarch64": "kARM64", "arm64": "kARM64",
                  "i686": "kX86", "armv7l": "kARM"}
_SYSTEMS = {"Linux": "kLinux", "Windows": "kWindows"}


def this_machine() -> tuple[str | None, str | None]:
    """(architecture, system) as libfranka names them; None where it has no name for it."""
    return _ARCHITECTURES.get(platform.machine().lower()), _SYSTEMS.get(platform.system())


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "franka-sim"


class ModelLibrary:
    """The model library of one arm description (built on first use, then kept)."""

    def __init__(self, description: ArmDescription) -> None:
        self.description = description
        self._bytes: bytes | None = None

    def for_client(self, request) -> bytes | None:
        """The library for a LoadModelLibrary request (its `architecture` and `system`), or
        None (logged) when this machine cannot make one for it."""
        wanted, here = (str(request.architecture), str(request.system)), this_machine()
        if wanted != here:
            log.warning("model library for %s/%s asked for, this machine makes one for %s/%s "
                        "only: answered kError", *wanted, *here)
            return None
        if self._bytes is None:
            self._bytes = self._build()
        return self._bytes

    def _build(self) -> bytes | None:
        source = c_source(self.description)
        name = hashlib.sha256(source.encode()).hexdigest()[:16]
        path = cache_dir() / f"model-library-{name}.so"
        if path.is_file():
            return path.read_bytes()
        compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
        if compiler is None:
            log.warning("no C compiler (cc, or $CC) to build the model library older "
                        "libfranka clients load: LoadModelLibrary answered kError")
            return None
        with tempfile.TemporaryDirectory() as work:
            c_file, so_file = Path(work, "model.c"), Path(work, "model.so")
            c_file.write_text(source)
            try:
                done = subprocess.run([compiler, "-O2", "-shared", "-fPIC", "-o", str(so_file),
                                       str(c_file), "-lm"], capture_output=True, text=True)
                failure = None if done.returncode == 0 else (
                    done.stderr.strip().splitlines()[-1:] or f"exit {done.returncode}")
            except OSError as exc:  # no such compiler, not executable
                failure = exc
            if failure is not None:
                log.warning("the model library did not compile (%s): %s: LoadModelLibrary "
                            "answered kError", compiler, failure)
                return None
            data = so_file.read_bytes()
        try:  # kept for the next time; a cache that cannot be written only costs a rebuild
            path.parent.mkdir(parents=True, exist_ok=True)
            kept = path.with_suffix(f".{os.getpid()}.tmp")
            kept.write_bytes(data)
            kept.replace(path)
        except OSError as exc:
            log.info("model library not kept in %s: %s", path.parent, exc)
        log.info("model library for %s built (%d bytes)", self.description.name, len(data))
        return data
