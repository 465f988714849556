"""`franka-sim serve --viewer`: MuJoCo's passive viewer on the running world.

The viewer renders from its own MjData on its own thread: ~30 times a second it copies the
world's qpos (a torn copy only shows for one frame; the cycle thread never waits for it, takes
no lock for it and is never called back), recomputes the kinematics of its copy and hands it to
the viewer. So rendering cannot delay a cycle; it only takes its share of the CPU.
"""

from __future__ import annotations

import logging
import os
import re
import threading
import time

log = logging.getLogger(__name__)

# s: a smooth view at half the CPU of 60 (with software GL a frame of the arm's look costs a
# good part of a core, which a lockstep client on a two-core machine then waits for)
FRAME_PERIOD = 1 / 30
OPEN_WITHIN = 30.0  # s a window may take to appear (software GL on a loaded machine)


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
        self._gui_failure: BaseException | None = None

    def start(self, timeout: float = OPEN_WITHIN) -> None:
        """Open the window, or raise RuntimeError saying why not.

        MuJoCo's launch_passive hands its handle back only once its GUI thread has made the
        window; should that thread fail (no GLX on the display, GLFW refusing), it never does
        and the caller would wait forever. So the GUI thread's exception is caught on its way
        out, and a window that has not come within `timeout` counts as one that cannot open."""
        _catch_gui_failures(self)
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self._ready.wait(0.05):
            if self._gui_failure is not None:
                exc = self._gui_failure
                self.error = RuntimeError(f"the viewer cannot open: {type(exc).__name__}: {exc}")
                break
            if time.monotonic() > deadline:
                self.error = RuntimeError(f"the viewer cannot open: no window within "
                                          f"{timeout:.0f} s (MuJoCo's GUI thread did not start)")
                break
        if self.error is not None:
            raise self.error
        log.info("the viewer shows the world")

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
        refused = _glfw_refusal()
        if refused:  # MuJoCo's own GUI thread would end the process with a bare "ERROR"
            self.error = RuntimeError(f"the viewer cannot open: {refused}")
            self._ready.set()
            return
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


def _glfw_refusal() -> str | None:
    """What GLFW said when it would not initialise on this display (None when it did)."""
    import warnings

    import glfw

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        if glfw.init():
            return None
    # GLFW's warnings read "(65550) b'X11: Failed to open display :9'": keep the words
    words = [re.sub(r"^\(\d+\) b['\"](.*)['\"]$", r"\1", str(w.message)) for w in said]
    return "; ".join(words) or "GLFW does not initialise"


_watched: list[LiveViewer] = []


def _catch_gui_failures(viewer: LiveViewer) -> None:
    """Route an exception that ends MuJoCo's GUI thread (its target is `_launch_internal`) to
    the viewer waiting for it; every other thread's goes on to the previous hook unchanged."""
    if not _watched:
        previous = threading.excepthook

        def hook(args) -> None:
            if args.thread is not None and "_launch_internal" in args.thread.name:
                for waiting in _watched:
                    waiting._gui_failure = args.exc_value
            previous(args)

        threading.excepthook = hook
    _watched.append(viewer)
