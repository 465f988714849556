"""`franka-sim serve --viewer`: MuJoCo's passive viewer on the running world, in a process of
its own.

Xlib ends the process whose display connection breaks (the X server stopped, `xkill`, a dropped
`ssh -X`); a viewer inside the server took the robot down with it. So the window belongs to a
child (`python -m franka_sim.server.viewer MODEL FD`): it loads the world's compiled model, and
~30 times a second the server's `fsim-viewer` thread sends it the world's positions (qpos, and
the mocap bodies' poses: the mobile base) over a socket pair (a torn copy only shows for one
frame; the cycle thread never waits for it, takes no lock for it and is never called back).
The child recomputes the kinematics of its own MjData and draws, at a lower priority than the
server (MuJoCo's viewer draws as fast as the display lets it: with software GL, most of a
core, which a realtime cycle must not have to share evenly). A frame the child has not taken
yet is dropped, never queued. Its window closed or its display gone, the child ends and the
server says so on one line and serves on; the server gone, its socket closes and the child
ends too.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

from franka_sim.log_names import ContextThread

log = logging.getLogger(__name__)

# s: a smooth view at half the CPU of 60 (with software GL a frame of the arm's look costs a
# good part of a core, which a lockstep client on a two-core machine then waits for)
FRAME_PERIOD = 1 / 30
OPEN_WITHIN = 30.0  # s a window may take to appear (software GL on a loaded machine)
CLOSE_WITHIN = 2.0  # s the child gets to close its window before it is killed
NICENESS = 10  # the child's: the server's cycle comes first when both want a core
READY, REFUSED = b"ready", b"refused "  # what the child says once, before any frame


class NoDisplay(RuntimeError):
    """The viewer needs a display (DISPLAY or WAYLAND_DISPLAY); the message says so."""


def check_display() -> None:
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise NoDisplay("--viewer needs a display (DISPLAY is not set); "
                        "`franka-sim render` makes a video without one")


class LiveViewer:
    """The server's side: starts the child, feeds it the world's qpos, notices its end."""

    def __init__(self, model, data) -> None:
        self.model, self.source = model, data
        self._stop = threading.Event()
        self._thread = ContextThread(target=self._feed, name="fsim-viewer", daemon=True)
        self._child: subprocess.Popen | None = None
        self._sock: socket.socket | None = None
        self._stderr = None
        self._starting = threading.Lock()  # the child is started under it
        self._abandoned = False  # the server stopped before the window opened

    def start(self, timeout: float = OPEN_WITHIN) -> None:
        """Open the window, or raise RuntimeError saying why not."""
        import mujoco

        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        fd, path = tempfile.mkstemp(prefix="franka-sim-viewer-", suffix=".mjb")
        os.close(fd)
        self._stderr = tempfile.TemporaryFile()
        self._sock = ours  # (closed by _end_child, however the start ends)
        try:
            mujoco.mj_saveModel(self.model, path, None)
            with self._starting:
                if self._abandoned:
                    raise RuntimeError("the viewer cannot open: the server is stopping")
                self._child = subprocess.Popen(
                    [sys.executable, "-P", "-m", "franka_sim.server.viewer", path,
                     str(theirs.fileno())], pass_fds=(theirs.fileno(),),
                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=self._stderr)
            theirs.close()  # (the child's alone now: its end reads as closed once it ends)
            ours.settimeout(timeout)
            said = ours.recv(4096)
        except TimeoutError:
            self._end_child()
            raise RuntimeError(f"the viewer cannot open: no window within {timeout:.0f} s")
        except BaseException:
            self._end_child()
            raise
        finally:
            theirs.close()
            os.unlink(path)
        if said != READY or self._abandoned:
            if self._abandoned:  # (it opened just as the server stopped)
                reason = "the server is stopping"
            elif said.startswith(REFUSED):
                reason = said[len(REFUSED):].decode(errors="replace")
            else:
                reason = self._last_words() or "its process ended"
            self._end_child()
            raise RuntimeError(f"the viewer cannot open: {reason}")
        ours.setblocking(False)
        self._thread.start()
        log.info("the viewer shows the world")

    def abandon(self) -> None:
        """The server stops while the window opens (another thread waits in `start`): its
        child is ended now, so `start` returns at once (with its RuntimeError) and no window
        outlives the server."""
        with self._starting:
            self._abandoned = True
            child = self._child
        if child is not None and child.poll() is None:
            child.kill()

    def stop(self) -> None:
        """Close the window: the child ends once its socket closes."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5.0)
        self._end_child()

    def _feed(self) -> None:
        data, sock, child = self.source, self._sock, self._child
        while not self._stop.wait(FRAME_PERIOD):
            if child.poll() is not None:
                self._say_ended(child.returncode)
                return
            try:
                sock.send(positions(data))  # a copy; the world may be mid-step
            except (BlockingIOError, InterruptedError):
                pass  # the child is behind: this frame is not shown
            except OSError:  # its end closed: it is ending (the next poll says how)
                pass

    def _say_ended(self, code: int) -> None:
        if code == 0:
            log.info("the viewer's window was closed; serving goes on")
            return
        words = self._last_words()
        log.warning("the viewer ended (%s%s); serving goes on",
                    f"exit code {code}" if code > 0 else f"signal {-code}",
                    f": {words}" if words else "")

    def _last_words(self) -> str:
        """What the child said of its end on stderr: Xlib's error, if it wrote one (its first
        line names it; the lines after are its serial numbers), else its last line."""
        if self._stderr is None:
            return ""
        self._stderr.seek(0)
        lines = [line.strip() for line in self._stderr.read().decode(errors="replace")
                 .splitlines() if line.strip()]
        for line in lines:
            if line.startswith(("X Error", "XIO", "X connection")):
                return line
        return lines[-1] if lines else ""

    def _end_child(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()
        child = self._child
        if child is not None and child.poll() is None:
            try:
                child.wait(CLOSE_WITHIN if sock is not None else 0.0)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        if self._stderr is not None:
            self._stderr.close()
            self._stderr = None


def positions(data) -> bytes:
    """What a frame carries: qpos, then each mocap body's position and quaternion."""
    return data.qpos.tobytes() + data.mocap_pos.tobytes() + data.mocap_quat.tobytes()


# -- the child -----------------------------------------------------------------------------------
def show(model_path: str, fd: int) -> int:
    """The viewer's process: the window until it is closed or the server's socket closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # (a terminal's Ctrl-C is the server's to act on)
    os.nice(NICENESS)
    sock = socket.socket(fileno=fd)
    refused = _glfw_refusal()
    if refused:  # MuJoCo's own GUI thread would end the process with a bare "ERROR"
        sock.send(REFUSED + refused.encode())
        return 1
    import mujoco
    import mujoco.viewer
    import numpy as np

    model = mujoco.MjModel.from_binary_path(model_path)
    data = mujoco.MjData(model)
    failures: list[BaseException] = []
    previous = threading.excepthook
    threading.excepthook = lambda args: failures.append(args.exc_value) or previous(args)
    before = set(threading.enumerate())
    try:  # (launch_passive hands back its handle once its GUI thread made the window)
        handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False,
                                              show_right_ui=False)
    except Exception as exc:  # noqa: BLE001 - said to the server
        sock.send(REFUSED + str(exc).encode())
        return 1
    if failures:
        sock.send(REFUSED + f"{type(failures[0]).__name__}: {failures[0]}".encode())
        return 1
    gui = [thread for thread in threading.enumerate() if thread not in before]
    _open_on_the_arms(handle, model, data)
    sock.send(READY)
    nq, nmocap = model.nq, model.nmocap
    size, served = len(positions(data)), True
    with handle:
        while served and handle.is_running():
            frame = None
            try:
                while got := sock.recv(size, socket.MSG_DONTWAIT):  # the newest frame sent
                    frame = got
                served = False  # (b"": the server closed its end)
            except (BlockingIOError, InterruptedError):
                pass
            except OSError:
                served = False
            if frame is not None and len(frame) == size:
                values = np.frombuffer(frame)
                data.qpos[:] = values[:nq]
                data.mocap_pos[:] = values[nq:nq + 3 * nmocap].reshape(nmocap, 3)
                data.mocap_quat[:] = values[nq + 3 * nmocap:].reshape(nmocap, 4)
                mujoco.mj_forward(model, data)
                handle.sync()
            time.sleep(FRAME_PERIOD)
    for thread in gui:  # (the process's exit ends GLFW: not while its GUI thread draws)
        thread.join(4.0)
    return 0


def _open_on_the_arms(handle, model, data) -> None:
    """The window's first view: every arm, as the web view opens on them."""
    import mujoco

    from franka_sim.physics.first_view import aim

    try:  # (a view it cannot place leaves MuJoCo's own: nothing to end the window for)
        mujoco.mj_forward(model, data)
        with handle.lock():
            aim(handle.cam, model, data)
    except Exception as exc:  # noqa: BLE001 - said on the child's stderr, the window opens
        print(f"the viewer's first view: {exc}", file=sys.stderr)


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


if __name__ == "__main__":
    sys.exit(show(sys.argv[1], int(sys.argv[2])))
