"""Genesis as this process uses it: whether it is installed, and its one initialisation.

Genesis (the `genesis` extra: genesis-world and torch) is imported only here and in the modules
of this package, and only when a world is built on it: the core install never imports it.
Genesis runs on a GPU where torch sees one, else on the CPU, in double precision as MuJoCo does.
"""

from __future__ import annotations

import atexit
import importlib.util
import os
import shutil
import tempfile
import threading
from pathlib import Path

INSTALL = "pip install 'franka-sim[genesis]'"
MISSING = f"--physics genesis needs the genesis extra: {INSTALL}"

_lock = threading.Lock()
_ready = False


def genesis_missing() -> str | None:
    """One line saying what to install for the Genesis engine; None if it is installed."""
    for module in ("genesis", "torch"):
        try:
            if importlib.util.find_spec(module) is None:
                return MISSING
        except (ImportError, ValueError):
            return MISSING
    return None


def genesis():
    """The initialised `genesis` module (initialised once per process)."""
    global _ready
    with _lock:
        import genesis as gs

        if not _ready:
            import torch

            backend = gs.gpu if torch.cuda.is_available() else gs.cpu
            gs.init(backend=backend, precision="64", logging_level="error", seed=0)
            _ready = True
        return gs


def write_mjcf(text: str, name: str) -> Path:
    """An MJCF document in a file of its own (Genesis loads a model from a file), kept for the
    life of the process in a per-process folder."""
    folder = Path(tempfile.gettempdir()) / f"franka-sim-genesis-{os.getpid()}"
    if not folder.is_dir():
        folder.mkdir()
        atexit.register(shutil.rmtree, folder, True)
    path = folder / f"{name}.xml"
    path.write_text(text)
    return path
