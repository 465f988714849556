"""A real X server for tests of what a user sees on a display: Debian's Xvfb on a free
display number, and screenshots of it (Pillow reads the screen over X)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time

import pytest


@contextlib.contextmanager
def xvfb(size: str = "1024x768x24"):
    """DISPLAY of an Xvfb started for the block, on a display number it picks itself
    (-displayfd), so concurrent sessions and workers never collide. Skips where Xvfb is not
    installed (.ci/run installs Debian's xvfb)."""
    if shutil.which("Xvfb") is None:
        pytest.skip("an X server is needed and Xvfb is not installed (apt-get install xvfb)")
    read, write = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", size,
                             "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    os.close(write)
    with os.fdopen(read) as told:
        number = told.readline().strip()  # written once it accepts clients; "" if it died
    if not number:
        proc.kill()
        raise RuntimeError(f"Xvfb did not start: {proc.communicate(timeout=10)[1]}")
    try:
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
