"""`serve --web PORT`: the web view of the running world, on its own thread.

viser serves the page (its prebuilt client, from the installed package: nothing is fetched)
and a WebSocket on its own thread and event loop. The view's own thread (`fsim-web`) draws:
while at least one browser is connected it reads the cycle thread's latest snapshot
(web/snapshots.py) ~30 times a second, moves the bodies that moved and updates each arm's
panel. With nobody connected the tap is detached from the cycle and the thread sleeps, so the
view costs the cycle one `if` per send and the process no CPU.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import io
import logging
import threading
import time

from franka_sim.log_names import ContextThread
from franka_sim.web.arm_panel import ArmPanel
from franka_sim.web.snapshots import SnapshotTap
from franka_sim.web.world_view import WorldView

log = logging.getLogger(__name__)

FRAME_PERIOD = 1 / 30  # s between two drawn frames while someone watches
STOP_WAIT = 1.0  # s a stop waits for viser's server to end
TITLE = "franka-sim"


class LiveView:
    """`model`, `data`: the world's (data is only read, by the cycle thread's snapshots);
    `arms`: (name, robot index) of each arm; `attach(tap | None)`: hand the tap to the cycle
    (CycleDriver.snapshots); `refresh(tap)`: have the cycle thread take a snapshot now."""

    def __init__(self, host: str, port: int, model, data, arms, *, attach, refresh) -> None:
        self.host, self.port = host, port
        self.model, self.arms = model, arms
        self.tap = SnapshotTap(data)
        self._attach, self._refresh = attach, refresh
        self._watchers = 0
        self._fresh = False  # a first watcher came since the panels were drawn
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread = ContextThread(target=self._run, name="fsim-web", daemon=True)
        self.server = None

    def start(self) -> None:
        """Serve the page on (host, port); OSError if the port cannot be had."""
        import viser

        quiet_libraries()
        with contextlib.redirect_stdout(io.StringIO()):  # viser's banner: we log one line
            server = viser.ViserServer(host=self.host, port=self.port, label=TITLE,
                                       verbose=False)
        # viser's share button opens a tunnel to a public relay: never from a robot's server.
        server.request_share_url = lambda verbose=True: None
        if self.port and server.get_port() != self.port:  # viser moves on to a free port
            stop_quietly(server)
            raise OSError(errno.EADDRINUSE, f"the web view's port {self.port} on {self.host} "
                          "is in use")
        self.port = server.get_port()
        self.server = server
        server.scene.set_up_direction("+z")
        server.gui.configure_theme(control_width="large", show_logo=False,
                                   show_share_button=False)
        self.world = WorldView(server.scene, self.model)
        self.panels = [ArmPanel(server.gui, name, index) for name, index in self.arms]
        server.on_client_connect(self._connected)
        server.on_client_disconnect(self._disconnected)
        self._thread.start()
        if self.host in ("0.0.0.0", "::"):  # (every address: a browser asks one of them)
            log.info("the web view is on port %d of every address (http://127.0.0.1:%d on "
                     "this machine)", self.port, self.port)
        else:
            log.info("the web view is on http://%s:%d", self.host, self.port)

    def stop(self) -> None:
        """Stop drawing and serving the page, within about STOP_WAIT: with a page open, viser's
        own stop waits seconds for its connection's end, which the rest of its stop then goes on
        waiting for in the background (a daemon thread: an exit does not wait for it)."""
        self._stop.set()
        self._wake.set()
        self._attach(None)
        if self._thread.is_alive():
            self._thread.join(2.0)
        if self.server is not None:
            stopping = threading.Thread(target=stop_quietly, args=(self.server,),
                                        name="fsim-web-stop", daemon=True)
            stopping.start()
            stopping.join(STOP_WAIT)
            self.server = None

    @property
    def watchers(self) -> int:
        return self._watchers

    def _connected(self, client) -> None:
        client.camera.position, client.camera.look_at = self.world.camera()
        with self._lock:
            self._watchers += 1
            if self._watchers == 1:
                self.tap.latest = None  # (taken for the last page, seconds or hours ago)
                self._fresh = True  # (the web thread restarts the panels' history)
                self._attach(self.tap)
                self._refresh(self.tap)  # a paused clock sends nothing: one snapshot now
                self._wake.set()
        log.info("a web watcher connected (%d watching)", self._watchers)

    def _disconnected(self, client) -> None:
        with self._lock:
            self._watchers -= 1
            if self._watchers == 0:
                self._attach(None)
                self._wake.clear()
        log.info("a web watcher left (%d watching)", self._watchers)

    def _run(self) -> None:
        _name_this_thread(b"fsim-web")
        shown, failed = None, False
        while not self._stop.is_set():
            self._wake.wait()  # (nobody watching: asleep; stop() wakes it too)
            if self._fresh:  # the first page since nobody watched: a history of its own
                self._fresh, shown = False, None
                for panel in self.panels:
                    panel.restart()
            now = time.monotonic()  # (before the snapshot: a held row never follows it)
            snapshot = self.tap.latest
            fresh = snapshot is not None and snapshot is not shown
            if fresh or shown is not None:  # (else: no state yet)
                shown = snapshot if fresh else shown
                try:
                    with self.server.atomic():
                        if fresh:
                            self.world.show(snapshot)
                        for panel in self.panels:
                            if fresh:
                                panel.show(snapshot)
                            else:  # no state since the last (a paused clock): it holds
                                panel.hold(now)
                except Exception:  # noqa: BLE001 - the view goes on; the robot never cares
                    if not failed:  # (once: not 30 tracebacks a second)
                        log.exception("the web view could not draw a frame")
                    failed = True
            self._stop.wait(FRAME_PERIOD)


def _name_this_thread(name: bytes) -> None:
    """The name top, ps -L and /proc show (benchmarks/web_watchers.py reads its CPU time)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(15, ctypes.c_char_p(name), 0, 0, 0)  # SET_NAME
    except (OSError, AttributeError):  # not Linux
        pass


def stop_quietly(server) -> None:
    with contextlib.redirect_stdout(io.StringIO()):  # ("Server stopped")
        server.stop()


def quiet_libraries() -> None:
    """A malformed request to the web port is the browser's problem, not the robot's: one
    line each (websockets logs a traceback per bad handshake by default), and one line per
    page or file the port does not have (a mistyped address), none per file it served."""
    class OneLine(logging.Filter):
        def filter(self, record: logging.LogRecord) -> bool:
            if record.exc_info:
                exc = record.exc_info[1]
                if _closed_unused(exc):
                    return False  # a browser's spare connection (a page closing): no request
                record.msg = f"web view: {record.getMessage()} ({type(exc).__name__}: {exc})"
                record.args, record.exc_info, record.exc_text = (), None, None
                record.levelno, record.levelname = logging.INFO, "INFO"  # not the robot's error
                return True
            if record.levelno >= logging.WARNING:
                return True
            return _refused_request(record)

    for name in ("websockets.server", "websockets"):
        logging.getLogger(name).addFilter(OneLine())
    logging.getLogger("websockets").setLevel(logging.WARNING)  # (each listen, each open)
    logging.getLogger("websockets.server").setLevel(logging.INFO)  # (its refusals: above)


def _closed_unused(exc: BaseException | None) -> bool:
    """A connection that closed before sending a byte (websockets says its handshake failed:
    an EOF after 0 bytes, under its InvalidMessage)."""
    while exc is not None:
        if isinstance(exc, EOFError) and "after 0 bytes" in str(exc):
            return True
        exc = exc.__cause__
    return False


def _refused_request(record: logging.LogRecord) -> bool:
    """websockets' "connection rejected" line of a page the port does not have, as "web view:
    PATH: 404 NOT FOUND"; its other lines are dropped (viser's files go out as handshakes
    rejected with 200; a failed handshake has its own line, above; listening, each watcher's
    connection)."""
    if record.msg != "connection rejected (%d %s)" or record.args[0] != 404:
        return False
    request = getattr(getattr(record, "websocket", None), "request", None)
    path = getattr(request, "path", "?")
    record.msg, record.args = "web view: %s: %d %s", (path, *record.args)
    return True
