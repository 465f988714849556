"""The web view's hand-off, without a browser or a server: the cycle thread's snapshot is a copy
taken at most every PERIOD after a send, and only while someone watches (the tap is attached
with the first watcher and detached with the last)."""

from __future__ import annotations

import threading
import types
from pathlib import Path

import mujoco
import numpy as np
import pytest

from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.web.snapshots import PERIOD, SnapshotTap

pytest.importorskip("viser", reason="the web view needs franka-sim[web] (viser)")


class Endpoint:
    def __init__(self) -> None:
        self.sent = []

    def send_state(self, data) -> None:
        self.sent.append(data)


def data_of_a_free_box():
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='.1 .1 .1' type='box'/></body>"
        "</worldbody></mujoco>")
    return mujoco.MjData(model)


def driver(endpoints) -> CycleDriver:
    made = CycleDriver(lambda physics: None, thread=None, lock=threading.Lock(), lockstep=False,
                       deliver=lambda replies, clients: None, clients=lambda: None,
                       has_client=lambda: True, watcher=None)
    made.endpoints = tuple(endpoints)
    return made


def test_a_snapshot_is_a_copy_of_what_was_sent_at_most_every_period():
    data = data_of_a_free_box()
    tap = SnapshotTap(data)
    endpoints = [Endpoint(), Endpoint()]
    cycle = driver(endpoints)
    cycle._send((b"a" * 8, None))  # nobody watching: nothing kept
    assert tap.latest is None and tap.taken == 0
    cycle.snapshots = tap
    first = cycle._send((b"one", None))
    assert tap.taken == 1 and tap.latest.states == (b"one", None)
    assert tap.latest.time == first and tap.due == first + PERIOD
    data.qpos[0] = 5.0  # the world moves on: the snapshot does not
    assert tap.latest.qpos[0] != 5.0
    cycle._send((b"two", b"x"))  # within PERIOD of the last one: not taken
    assert tap.taken == 1 and tap.latest.states == (b"one", None)
    tap.due = 0.0  # (PERIOD has passed)
    cycle._send((b"three", b"y"))
    assert tap.taken == 2 and tap.latest.states == (b"three", b"y")
    assert tap.latest.qpos[0] == 5.0
    assert [e.sent for e in endpoints] == [[b"a" * 8, b"one", b"two", b"three"], [b"x", b"y"]]


def test_the_tap_is_attached_only_while_someone_watches():
    from franka_sim.web.live import LiveView

    data = data_of_a_free_box()
    attached, refreshed = [], []
    view = LiveView("127.0.0.1", 0, data.model, data, [], attach=attached.append,
                    refresh=refreshed.append)
    view.world = types.SimpleNamespace(camera=lambda: ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)))
    view.tap.latest = "the last page's snapshot"
    view._connected(Client())
    assert view.tap.latest is None and view._fresh  # (a history of its own: below)
    view._connected(Client())
    assert attached == [view.tap] and refreshed == [view.tap] and view.watchers == 2
    view._disconnected(None)
    assert attached == [view.tap]
    view._disconnected(None)
    assert attached == [view.tap, None] and view.watchers == 0


class Client:
    class camera:  # noqa: N801 - what viser's ClientHandle offers
        position = look_at = None


class Field:
    def __init__(self, value=None) -> None:
        self.value = value

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass


class Gui:
    """What ArmPanel asks of viser's GuiApi, each field a plain value holder."""

    def add_folder(self, label):
        return Field()

    def add_text(self, label, initial_value, **kwargs):
        return Field(initial_value)

    def add_dropdown(self, label, options, initial_value=None, **kwargs):
        return Field(initial_value)

    def add_uplot(self, data, series, **kwargs):
        plot = Plot(data)
        plot.scales = kwargs["scales"]
        plot.order = kwargs.get("order") or float(id(plot))
        return plot


class Plot(Field):
    """A uPlot's handle: its data is what it draws (`value` here)."""

    removed = False

    def remove(self) -> None:
        self.removed = True

    @property
    def data(self):
        return self.value

    @data.setter
    def data(self, values) -> None:
        self.value = values


def test_the_panel_notes_each_change_of_mode_errors_and_reflex_once():
    from franka_sim.protocol.codec import STATE_DTYPE
    from franka_sim.protocol.enums import RobotMode
    from franka_sim.protocol.errors import ERROR_NAMES
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.snapshots import Snapshot

    panel = ArmPanel(Gui(), "fr3", 0, t0=0.0)
    reflex = ERROR_NAMES.index("joint_position_limits_violation")

    def show(t, mode, error=None):
        state = np.zeros(1, STATE_DTYPE)[0]
        state["robot_mode"] = int(mode)
        if error is not None:
            state["errors"][error] = state["reflex_reason"][error] = 1
        panel.show(Snapshot(t, (state.tobytes(),), None, None, None))

    show(0.0, RobotMode.kIdle)
    show(0.5, RobotMode.kMove)
    show(0.6, RobotMode.kMove)  # no change: no line
    show(1.0, RobotMode.kReflex, reflex)
    assert panel.mode.value == "Reflex"
    assert panel.errors.value == panel.reflex.value == "joint_position_limits_violation"
    assert panel.events.value.splitlines() == [
        "1.000 s: Reflex; errors: joint_position_limits_violation; "
        "reflex: joint_position_limits_violation",
        "0.500 s: Move",
        "0.000 s: Idle; errors: none"]
    assert panel.plots is not None and len(panel.plots[0].value[0]) >= 2  # (made, with data)


def test_a_state_no_other_follows_holds_in_the_plots():
    """A paused clock sends no state: a watcher who came then sees its one state drawn, held
    up to now, and the plots go on from it once states flow again."""
    from franka_sim.protocol.codec import STATE_DTYPE
    from franka_sim.web.arm_panel import PLOT_PERIOD, WINDOW, ArmPanel
    from franka_sim.web.snapshots import Snapshot

    panel = ArmPanel(Gui(), "fr3", 0)
    state = np.zeros(1, STATE_DTYPE)[0]
    state["q"] = state["q_d"] = np.arange(7) / 10

    def show(t: float) -> None:
        panel.show(Snapshot(t, (state.tobytes(),), None, None, None))

    show(100.0)
    panel.hold(100.0 + PLOT_PERIOD / 2)
    assert panel.plots is None  # (one state, not yet held for a plot's period)
    period = PLOT_PERIOD * 1.001  # (a period after, in floats)
    panel.hold(100.0 + period)
    t, q, q_d = panel.plots[0].value
    assert list(t) == pytest.approx([0.0, period]) and list(q) == list(q_d) == [0.0, 0.0]
    for now in np.arange(1, 60) * PLOT_PERIOD * 2:
        panel.hold(100.0 + now)
    t = panel.plots[0].value[0]
    assert t[-1] == pytest.approx(59 * PLOT_PERIOD * 2) and t[-1] - t[0] <= WINDOW
    state["q"][0] = 0.5
    show(130.0)
    panel.hold(130.0 + PLOT_PERIOD / 2)  # (a state came: nothing is held within a period)
    panel.hold(130.0 + period)
    t, q, _ = panel.plots[0].value
    assert list(t[-2:]) == pytest.approx([30.0, 30.0 + period]) and list(q[-2:]) == [0.5, 0.5]


def test_a_page_opened_after_everyone_left_starts_its_own_history():
    """The plots' time axis counts from the first state the page was shown, not from the
    first page's; its events are its own."""
    from franka_sim.protocol.codec import STATE_DTYPE
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.snapshots import Snapshot

    panel = ArmPanel(Gui(), "fr3", 0)
    state = np.zeros(1, STATE_DTYPE)[0]
    for t in (100.0, 100.5, 101.0):
        state["q"][0] = t / 1000
        panel.show(Snapshot(t, (state.tobytes(),), None, None, None))
    panel.restart()
    for t in (130.0, 130.5):
        state["q"][0] = t / 1000
        panel.show(Snapshot(t, (state.tobytes(),), None, None, None))
    assert list(panel.plots[0].value[0]) == [0.0, 0.5]
    assert panel.events.value.splitlines() == ["0.000 s: Other; errors: none"]


def test_a_plot_whose_values_are_all_zero_shows_them_about_zero():
    """uPlot shows values that are all 0 on 0 to 100 (q at 0 rad, no external force): such a
    plot gets -1 to 1 until a value is not 0."""
    from franka_sim.protocol.codec import STATE_DTYPE
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.snapshots import Snapshot

    panel = ArmPanel(Gui(), "fr3", 0, t0=0.0)
    state = np.zeros(1, STATE_DTYPE)[0]
    state["tau_J"][0] = state["tau_J_d"][0] = 1.5

    def show(t: float) -> None:
        panel.show(Snapshot(t, (state.tobytes(),), None, None, None))

    show(0.0)
    show(1.0)
    q, tau, force, rate = panel.plots
    assert q.scales["y"] == force.scales["y"] == rate.scales["y"] == {
        "auto": False, "range": [-1.0, 1.0]}
    assert tau.scales["y"] == {"auto": True}
    state["q"][0] = 0.25
    show(2.0)
    # Another scale is a plot of its own, in the place of the one it replaces (viser's uPlot
    # given new scales keeps its time axis where it was).
    assert panel.plots[0].scales["y"] == {"auto": True} and q.removed
    assert panel.plots[0].order == q.order and panel.plots[1:] == (tau, force, rate)
    assert force.scales["y"]["range"] == [-1.0, 1.0] and not force.removed


def test_a_recordings_panel_shows_the_events_and_plots_as_recorded_whatever_the_scrubbing():
    from franka_sim.recording.reader import open_recording
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.recording_view import timeline_of

    recording = open_recording(Path(__file__).resolve().parents[1] / "data" / "older_libfranka"
                               / "0.13.6" / "generate_joint_position_motion.mcap")
    timeline = timeline_of(recording)
    ids = timeline.ids[0]
    modes = recording.states()["robot_mode"]
    changed = [0, *np.flatnonzero(modes[1:] != modes[:-1]) + 1]
    # when the mode changed, from the recording's start (its first pose of the world)
    recorded = [f"{(ids[j] - timeline.first) / 1000:.3f} s" for j in changed]
    panel = ArmPanel(Gui(), "fr3", 0, t0=0.0)
    end = timeline.duration

    def show(seconds: float) -> None:
        panel.show_recorded(timeline.at(seconds), timeline.rows(0, seconds),
                            *timeline.events(0, seconds))

    for seconds in (1.0, 12.5, 3.0, 0.0, end):  # scrubbed back and forth, as a user does
        show(seconds)
    assert [line.split(":")[0] for line in reversed(panel.events.value.splitlines())] == \
        recorded[-6:]
    t = panel.plots[0].value[0]  # the q plot's times: the recorded window before the end
    assert t[-1] == pytest.approx((ids[-1] - timeline.first) / 1000)  # (the arm's last state)
    assert t[0] == pytest.approx(max(0.0, end - 10.0), abs=0.01)
    assert np.all(np.diff(t) > 0)


def test_a_moment_with_no_state_of_the_arm_in_its_window_shows_its_plots_empty():
    """Typed past the arm's last state by more than the plots' window (10 s): its plots show
    that window empty, not the curves of the moment shown before (the state at both moments
    is the arm's last, the one shown before)."""
    from franka_sim.recording.reader import open_recording
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.recording_view import timeline_of

    recording = open_recording(Path(__file__).resolve().parents[1] / "data" / "older_libfranka"
                               / "0.13.6" / "generate_joint_position_motion.mcap")
    timeline = timeline_of(recording)
    end = timeline.duration
    panel = ArmPanel(Gui(), "fr3", 0, t0=0.0)
    for seconds in (end, end + 30.0):
        panel.show_recorded(timeline.at(seconds), timeline.rows(0, seconds),
                            *timeline.events(0, seconds))
    assert timeline.rows(0, end + 30.0) == []
    for plot in panel.plots:
        t, *values = plot.value
        assert t[-1] - t[0] == pytest.approx(10.0) and np.isnan(values).all()


def test_a_recordings_last_reflex_is_the_one_before_the_moment_shown(tmp_path):
    from franka_sim.recording.reader import open_recording
    from franka_sim.web.arm_panel import ArmPanel
    from franka_sim.web.recording_view import timeline_of
    from recording.conftest import record_session  # (a motion, then a reflex, then recovery)

    record_session(tmp_path / "run.mcap", "lockstep")
    recording = open_recording(tmp_path / "run.mcap")
    timeline = timeline_of(recording)
    panel = ArmPanel(Gui(), "fr3", 0, t0=0.0)
    for seconds in (timeline.duration, 0.0):  # the end, then scrubbed back to the start
        panel.show_recorded(timeline.at(seconds), timeline.rows(0, seconds),
                            *timeline.events(0, seconds))
        if seconds:
            assert "discontinuity" in panel.reflex.value
    assert panel.reflex.value == "none" and panel.mode.value == "Idle"


def test_a_recordings_mobile_base_stands_where_its_states_put_it(tmp_path):
    """The base is a mocap body, not in the recorded qpos: `view` and `render` put it where
    its recorded states (its odometry) had it, and its drive is on the timeline."""
    import json
    import math
    import subprocess
    import sys

    from franka_sim.physics.mobile_base import BASE_BODY
    from franka_sim.recording.reader import open_recording
    from franka_sim.testing import ServerProcess, fresh_loopback_address
    from franka_sim.web.recording_view import timeline_of

    base, left, right = (fresh_loopback_address() for _ in range(3))
    path = tmp_path / "duo.mcap"
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                           f"right={right}", "--mobile-base", base, "--clock", "lockstep",
                           "--record", str(path)).wait_ready()
    try:
        done = subprocess.run([sys.executable, str(Path(__file__).resolve().parents[1]
                                                   / "mobile" / "base_program.py"),
                               base, "0.2", "0.0", "0.3", "1.5"],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        after = json.loads(done.stdout.strip().splitlines()[-1])["after"]  # (x, y, yaw)
    finally:
        server.stop()
    timeline = timeline_of(open_recording(path))
    m = int(timeline.model.body_mocapid[timeline.model.body(BASE_BODY).id])
    start, end = timeline.at(0.0), timeline.at(timeline.duration)
    assert timeline.duration > 1.4  # the arms sent nothing: the span is the base's drive
    np.testing.assert_allclose(start.mocap_pos[m][:2], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(end.mocap_pos[m][:2], after[:2], atol=1e-4)
    yaw = 2 * math.atan2(end.mocap_quat[m][3], end.mocap_quat[m][0])
    assert yaw == pytest.approx(after[2], abs=1e-4) and abs(yaw) > 0.1
    # `plot` draws the base's pose and twist, not joints: the pose ends where the drive did.
    pytest.importorskip("matplotlib")
    from franka_sim.playback.plot import figure

    from franka_sim.playback.plot import PlotError

    recording = open_recording(path)
    with pytest.raises(PlotError, match="the mobile base has no joints"):
        figure(recording, joints=[0, 1], robot="base")
    fig = figure(recording)  # (the base: the first robot that sent a state)
    assert fig.axes[0].get_title().endswith("states of base")
    pose, twist, *_ = fig.axes
    assert [ax.get_ylabel() for ax in fig.axes] == [
        "base pose", "twist [m/s, rad/s]", "success rate", "robot mode"]
    x, y, drawn_yaw = (line.get_ydata() for line in pose.get_lines()[:3])
    np.testing.assert_allclose([x[-1], y[-1], drawn_yaw[-1]], after, atol=1e-4)
    assert np.nanmax(twist.get_lines()[0].get_ydata()) == pytest.approx(0.2, abs=1e-3)
    # `render` draws the same drive: its last frame is not its first.
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    video = tmp_path / "duo.mp4"
    done = subprocess.run([sys.executable, "-m", "franka_sim", "render", str(path), "-o",
                           str(video), "--fps", "5"], capture_output=True, text=True, timeout=300)
    if "no offscreen OpenGL" in done.stderr:
        pytest.skip(done.stderr.strip())
    assert done.returncode == 0, done.stderr
    frames = [np.frombuffer(f, np.uint8).astype(int)
              for f in list(imageio_ffmpeg.read_frames(str(video)))[1:]]
    assert len(frames) > 5 and np.abs(frames[-1] - frames[0]).mean() > 3


def test_the_viewers_free_camera_orbits_to_the_web_views_first_view():
    """The MuJoCo viewer's camera (distance, azimuth, elevation about look_at) stands where
    the web view's first view does."""
    import math

    from franka_sim.physics.first_view import orbit

    position, look_at = np.array([1.5, -1.2, 1.1]), np.array([0.3, 0.0, 0.35])
    distance, azimuth, elevation = orbit(position, look_at)
    a, e = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    np.testing.assert_allclose(look_at - distance * forward, position, atol=1e-12)


def test_a_stop_does_not_wait_for_the_pages_connection_to_end():
    """viser's stop waits seconds for an open page's connection; the view's stop waits for it
    at most STOP_WAIT, and the rest of viser's stop goes on in the background."""
    import time

    from franka_sim.web.live import STOP_WAIT, LiveView

    data = data_of_a_free_box()
    view = LiveView("127.0.0.1", 0, data.model, data, [], attach=lambda tap: None,
                    refresh=lambda tap: None)
    ended = threading.Event()

    class Server:  # viser's, with a page whose connection takes long to end
        def stop(self):
            ended.wait(30)

    view.server = Server()
    began = time.monotonic()
    view.stop()
    took = time.monotonic() - began
    ended.set()
    assert STOP_WAIT <= took < 10 and view.server is None
