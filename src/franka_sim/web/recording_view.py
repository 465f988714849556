"""`franka-sim view RECORDING`: a recording in the web view, with a timeline to scrub or play.

The recorded world is built as `render` and `replay` build it (WorldParts from the
recording's metadata). A moment of the timeline is a snapshot like the live view's: each arm's
recorded state sent nearest that cycle, the world's recorded positions before it, so the 3D
view and the arm panels are the live view's own (web/world_view.py, web/arm_panel.py).
"""

from __future__ import annotations

import contextlib
import io
import signal
import tempfile
import threading
import time

import numpy as np

from franka_sim.playback.recorded_world import RecordedWorld
from franka_sim.web.arm_panel import (EVENTS, WINDOW, ArmPanel, event_line, row_of,
                                      status_of)
from franka_sim.web.live import TITLE, quiet_libraries, stop_quietly
from franka_sim.web.snapshots import Snapshot
from franka_sim.web.world_view import WorldView

FRAME_PERIOD = 1 / 30  # s between two frames while playing
SPEEDS = ("0.25", "0.5", "1", "2", "4")
PLOT_POINTS = 1000  # most rows a plot gets of its window (10 s of states is 10000)


class RecordingTimeline(RecordedWorld):
    """What the recording shows at each moment (no GUI: tests read it directly): the world
    (playback/recorded_world.py), and each arm's plots' rows and events as recorded."""

    def __init__(self, recording, physics) -> None:
        super().__init__(recording, physics)
        self._changes = [self._status_changes(states, ids)
                         for states, ids in zip(self.states, self.ids)]

    def _status_changes(self, states, ids) -> tuple[np.ndarray, list[str], list[str]]:
        """The cycles where an arm's mode, errors or reflex reasons change, the events
        readout's line for each, and the last reflex's reasons as of each."""
        if not len(ids):
            return np.zeros(0, np.int64), [], []
        n = len(ids)
        key = np.concatenate([states[name].reshape(n, -1).astype(np.int64)
                              for name in ("robot_mode", "errors", "reflex_reason")], axis=1)
        changed = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
        lines, reflexes, before, reflex = [], [], None, "none"
        for j in changed:
            status = status_of(states[j])
            lines.append(event_line(before, status, (ids[j] - self.first) / 1000.0))
            reflex = status[2] if status[2] != "none" else reflex
            reflexes.append(reflex)
            before = status
        return ids[changed], lines, reflexes

    def rows(self, arm: int, seconds: float) -> list:
        """Arm `arm`'s plots' rows over the WINDOW up to `seconds`, as recorded (at most
        PLOT_POINTS, evenly taken)."""
        states, ids = self.states[arm], self.ids[arm]
        cycle = self.first + int(round(seconds * 1000.0))
        hi = int(ids.searchsorted(cycle, side="right"))
        lo = int(ids.searchsorted(cycle - int(WINDOW * 1000), side="left"))
        step = max(1, (hi - lo) // PLOT_POINTS)
        return [row_of(states[j], (ids[j] - self.first) / 1000.0) for j in range(lo, hi, step)]

    def events(self, arm: int, seconds: float) -> tuple[list[str], str]:
        """Arm `arm`'s last EVENTS changes up to `seconds`, and its last reflex's reasons then
        ("none": none yet), as recorded."""
        cycles, lines, reflexes = self._changes[arm]
        k = int(cycles.searchsorted(self.first + int(round(seconds * 1000.0)), side="right"))
        return lines[max(0, k - EVENTS):k], reflexes[k - 1] if k else "none"

    @property
    def duration(self) -> float:
        """s of robot time from the first state to the last."""
        return (self.last - self.first) / 1000.0

    def at(self, seconds: float) -> Snapshot:
        """The world at `seconds` of robot time after the first state."""
        cycle = self.first + int(round(seconds * 1000.0))
        qpos, sent, mocap_pos, mocap_quat = self.at_cycle(cycle)
        return Snapshot(seconds, sent, qpos, mocap_pos, mocap_quat)


def timeline_of(recording, meshes=None) -> RecordingTimeline:
    """The recording's timeline over the world it was made in (`meshes`: how it is drawn)."""
    from franka_sim.playback.recorded_world import recorded_physics

    with tempfile.TemporaryDirectory(prefix="franka-sim-view-") as workdir:
        _, _, physics = recorded_physics(recording, workdir, meshes)
    return RecordingTimeline(recording, physics)


def serve_recording(recording, host: str, port: int, meshes=None) -> None:
    """Serve the view of `recording` until Ctrl-C or SIGTERM (OSError: the port cannot be
    had)."""
    import viser

    timeline = timeline_of(recording, meshes)
    _check_address(host, port)
    quiet_libraries()
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host=host, port=port, label=f"{TITLE}: {recording.path.name}",
                                   verbose=False)
    server.request_share_url = lambda verbose=True: None  # (never a tunnel: live.py)
    if server.get_port() != port:
        stop_quietly(server)
        raise OSError(f"port {port} on {host} is in use")
    server.scene.set_up_direction("+z")
    server.gui.configure_theme(control_width="large", show_logo=False, show_share_button=False)
    world = WorldView(server.scene, timeline.model)
    with server.gui.add_folder("timeline"):
        slider = server.gui.add_slider("time (s)", min=0.0, max=max(timeline.duration, 0.001),
                                       step=0.001, initial_value=0.0)
        play = server.gui.add_button("play / pause")
        speed = server.gui.add_dropdown("speed", SPEEDS, initial_value="1")
    panels = [ArmPanel(server.gui, name, i, t0=0.0) for i, name in enumerate(timeline.names)]
    playing = threading.Event()
    lock = threading.Lock()

    def show(seconds: float) -> None:
        with lock, server.atomic():
            snapshot = timeline.at(seconds)
            world.show(snapshot)
            for i, panel in enumerate(panels):
                panel.show_recorded(snapshot, timeline.rows(i, seconds),
                                    *timeline.events(i, seconds))

    def scrubbed(_event) -> None:
        seconds = min(max(float(slider.value), 0.0), timeline.duration)
        if seconds != slider.value:  # a time typed into the box outside the recording
            slider.value = seconds  # (the box says where it is; its on_update shows it)
            return
        show(seconds)

    slider.on_update(scrubbed)
    play.on_click(lambda _event: playing.clear() if playing.is_set() else playing.set())

    @server.on_client_connect
    def _(client) -> None:
        client.camera.position, client.camera.look_at = world.camera()

    show(0.0)
    print(f"franka-sim: {recording.path} on http://{host}:{server.get_port()} (Ctrl-C ends)",
          flush=True)
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():  # (SIGTERM ends it as Ctrl-C)
        signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    last = time.monotonic()
    try:
        while not stop.wait(FRAME_PERIOD):
            now = time.monotonic()
            elapsed, last = now - last, now
            if playing.is_set():  # (by the time that passed: a slow frame does not slow it)
                t = slider.value + elapsed * float(speed.value)
                if t >= timeline.duration:
                    t = timeline.duration
                    playing.clear()
                slider.value = t  # (its on_update shows it)
    except KeyboardInterrupt:
        pass
    finally:
        stop_quietly(server)


def _check_address(host: str, port: int) -> None:
    """OSError saying why the page cannot be served on (host, port): viser itself would try
    the next thousand ports of a host that does not resolve, saying nothing meanwhile."""
    import errno

    from franka_sim.server.binding import bound_socket

    try:
        bound_socket(host, port).close()
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise OSError(f"port {port} on {host} is in use") from None
        raise OSError(f"{host}:{port} cannot be served: {exc.strerror or exc}") from None
