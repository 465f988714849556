"""A real X server for tests of what a user sees on a display: Debian's Xvfb on a free
display number, and screenshots of it (Pillow reads the screen over X)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest


def _free_display() -> int:
    for number in range(90 + os.getpid() % 300, 1000):
        if not Path(f"/tmp/.X11-unix/X{number}").exists() and \
                not Path(f"/tmp/.X{number}-lock").exists():
            return number
    raise RuntimeError("no free X display number")


@contextlib.contextmanager
def xvfb(size: str = "1024x768x24"):
    """DISPLAY of an Xvfb started for the block (skips where Xvfb is not installed)."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (.ci/run installs Debian's xvfb)")
    number = _free_display()
    proc = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", size, "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        socket_path = Path(f"/tmp/.X11-unix/X{number}")
        deadline = time.monotonic() + 30
        while not socket_path.exists():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"Xvfb :{number} did not start")
            time.sleep(0.05)
        yield f":{number}"
    finally:
        proc.terminate()
        proc.wait(10)


def screenshot(display: str):
    """The whole screen as a numpy array (height, width, 3)."""
    import numpy as np
    from PIL import ImageGrab

    return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))


def wait_for_screen(display: str, changed_from=None, timeout: float = 60.0):
    """The screen once something is drawn on it (not all one colour), or once it differs from
    `changed_from`; AssertionError when that does not happen within `timeout`."""
    import numpy as np

    deadline = time.monotonic() + timeout
    while True:
        shot = screenshot(display)
        drawn = shot.min() != shot.max()
        if drawn and (changed_from is None or not np.array_equal(shot, changed_from)):
            return shot
        assert time.monotonic() < deadline, "the screen did not change"
        time.sleep(0.1)
