"""A real X server for tests of what a user sees on a display: Debian's Xvfb on a free
display number, and screenshots of it (Pillow reads the screen over X)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import time

import pytest

SERVERS: dict[str, subprocess.Popen] = {}  # each running Xvfb by its DISPLAY (a test may kill it)


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
    SERVERS[f":{number}"] = proc
    try:
        yield f":{number}"
    finally:
        del SERVERS[f":{number}"]
        proc.terminate()
        proc.wait(10)


# A window of one colour drawn through GLFW and OpenGL, the path MuJoCo's viewer takes, kept up
# until its stdin closes.
_PROBE = """
import sys, glfw
from OpenGL import GL
if not glfw.init():
    sys.exit("GLFW does not initialise on this display")
window = glfw.create_window(160, 120, "probe", None, None)
if not window:
    sys.exit("GLFW makes no OpenGL window on this display")
glfw.make_context_current(window)
GL.glClearColor(1.0, 0.0, 1.0, 1.0)
GL.glClear(GL.GL_COLOR_BUFFER_BIT)
glfw.swap_buffers(window)
print(GL.glGetString(GL.GL_RENDERER).decode(), flush=True)
sys.stdin.read()
"""


def opengl_window_problem(display: str, timeout: float = 30.0) -> str | None:
    """Why this X server shows no OpenGL window (None when it does): a probe of our own draws
    a magenta window through GLFW, as the viewer would, and the screen is read back. A test of
    the viewer skips with this reason, so a machine without working GL says so instead of
    passing for a viewer that was never drawn."""
    import sys

    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    proc = subprocess.Popen([sys.executable, "-c", _PROBE], env={**env, "DISPLAY": display},
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        renderer = proc.stdout.readline().strip()
        if not renderer:
            proc.wait(timeout)
            return f"the OpenGL probe failed: {proc.stderr.read().strip()}"
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            shot = screenshot(display)
            if ((shot[..., 0] == 255) & (shot[..., 1] == 0) & (shot[..., 2] == 255)).any():
                return None
            time.sleep(0.1)
        return f"an OpenGL window ({renderer}) does not reach the screen"
    finally:
        proc.kill()
        proc.wait()
        for pipe in (proc.stdin, proc.stdout, proc.stderr):
            pipe.close()


@contextlib.contextmanager
def opengl_display():
    """DISPLAY of an Xvfb on which an OpenGL window reaches the screen; skips, saying why,
    where that is not so (no Xvfb, or no working GL on it)."""
    with xvfb() as display:
        problem = opengl_window_problem(display)
        if problem is not None:
            pytest.skip(f"this X server shows no OpenGL window: {problem}")
        yield display


def screenshot(display: str):
    """The whole screen as a numpy array (height, width, 3)."""
    import numpy as np
    from PIL import ImageGrab

    return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))


def wait_for_screen(display: str, changed_from=None, timeout: float = 60.0, server=None):
    """The screen once something is drawn on it (not all one colour), or once it differs from
    `changed_from`; AssertionError when that does not happen within `timeout`, or at once when
    `server` (the ServerProcess drawing it) has exited: the message carries its log."""
    import numpy as np

    deadline = time.monotonic() + timeout
    while True:
        shot = screenshot(display)
        drawn = shot.min() != shot.max()
        if drawn and (changed_from is None or not np.array_equal(shot, changed_from)):
            return shot
        log = "" if server is None else "; its log:\n" + "\n".join(server.lines)
        assert server is None or server.proc.poll() is None, f"the server exited{log}"
        assert time.monotonic() < deadline, f"the screen did not change{log}"
        time.sleep(0.1)
