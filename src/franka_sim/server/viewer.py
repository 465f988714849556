"""`franka-sim serve --viewer`: MuJoCo's passive viewer on the running world.

The viewer renders from its own MjData on its own thread: ~60 times a second it copies the
world's qpos (a torn copy only shows for one frame; the cycle thread never waits for it, takes
no lock for it and is never called back), recomputes the kinematics of its copy and hands it to
the viewer. So rendering cannot delay a cycle; it only takes its share of the CPU.
"""

from __future__ import annotations

import logging
import os
import threading
import time

log = logging.getLogger(__name__)

FRAME_PERIOD = 1 / 60  # s


class NoDisplay(RuntimeError):
    """The viewer needs a display (DISPLAY or WAYLAND_DISPLAY); the message says so."""


def check_display() -> None:
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise NoDisplay("--viewer needs a display (DISPLAY is not set); "
                        "`franka-sim render` makes a video without one")


class LiveViewer:
    def __init__(self, model, data) -> None:
        self.model, self.source = model, data
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fsim-viewer", daemon=True)
        self._ready = threading.Event()
        self.error: Exception | None = None

    def start(self, timeout: float = 10.0) -> None:
        """Open the window (NoDisplay / RuntimeError if it cannot)."""
        self._thread.start()
        self._ready.wait(timeout)
        if self.error is not None:
            raise self.error

    def stop(self) -> None:
        """Close the window and wait until MuJoCo's GUI thread has let go of GLFW: the
        process's exit terminates GLFW, and a GUI thread still drawing then would crash it."""
        self._stop.set()
        self._thread.join(5.0)

    def _run(self) -> None:
        import mujoco
        import mujoco.viewer

        model = self.model
        data = mujoco.MjData(model)
        before = set(threading.enumerate())
        try:
            handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False,
                                                  show_right_ui=False)
        except Exception as exc:  # noqa: BLE001 - reported by start()
            self.error = RuntimeError(f"the viewer cannot open: {exc}")
            self._ready.set()
            return
        # The thread launch_passive started draws the window until the handle is closed.
        gui = [thread for thread in threading.enumerate() if thread not in before]
        self._ready.set()
        with handle:
            while handle.is_running() and not self._stop.is_set():
                data.qpos[:] = self.source.qpos  # a copy; the world may be mid-step
                mujoco.mj_forward(model, data)
                handle.sync()
                time.sleep(FRAME_PERIOD)
        for thread in gui:
            thread.join(4.0)
