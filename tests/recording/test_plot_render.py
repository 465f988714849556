"""Plot and render of a recorded pylibfranka session, and what they say to bad input."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.recording import FORMAT_VERSION
from franka_sim.playback.plot import DPI, PANEL_HEIGHT, WIDTH
from franka_sim.recording.reader import open_recording
from franka_sim.playback.render import HEIGHT, WIDTH as VIDEO_WIDTH, frame_cycles


def franka_sim(*args: str) -> subprocess.CompletedProcess:
    """The command as a user runs it: MUJOCO_GL unset (render picks its offscreen GL)."""
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    return subprocess.run([sys.executable, "-m", "franka_sim", *args], capture_output=True,
                          text=True, timeout=300, env=env)


def test_plot_writes_a_png_of_the_expected_size_with_no_blank_panel(lockstep_run, tmp_path):
    image_io = pytest.importorskip("matplotlib.image")
    path, _ = lockstep_run
    out = tmp_path / "run.png"
    done = franka_sim("plot", str(path), "-o", str(out), "--joints", "1,4", "--fields", "elbow")
    assert done.returncode == 0, done.stderr
    image = image_io.imread(out)
    panels = 8  # q, dq, tau, wrench, success, timeline, the Hand's width, elbow
    assert image.shape[:2] == (round(PANEL_HEIGHT * panels * DPI), round(WIDTH * DPI))
    # Each panel's band holds more than its frame: coloured (non-grey) pixels drawn in it.
    rgb = image[..., :3]
    coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 0.2
    bands = np.array_split(coloured, panels, axis=0)
    dark = rgb.max(axis=2) < 0.3  # black lines (success rate, robot mode)
    for k, (band, ink) in enumerate(zip(bands, np.array_split(dark, panels, axis=0))):
        assert band.sum() + ink.sum() > 2000, f"panel {k} looks blank"


def test_plot_window_from_to(lockstep_run, tmp_path):
    pytest.importorskip("matplotlib")
    path, _ = lockstep_run
    t = open_recording(path).states()["message_id"] / 1000  # the robot's time, s
    start = t[len(t) // 3]  # a window of 0.2 s from a state of the recorded session
    done = franka_sim("plot", str(path), "-o", str(tmp_path / "w.png"), "--from", f"{start}",
                      "--to", f"{start + 0.2}")
    assert done.returncode == 0, done.stderr
    done = franka_sim("plot", str(path), "-o", str(tmp_path / "w.png"), "--from", "1e6")
    assert done.returncode == 1 and done.stderr.count("\n") == 1
    assert "no state in the window" in done.stderr
    done = franka_sim("plot", str(path), "-o", str(tmp_path / "w.png"), "--from", "5",
                      "--to", "2")
    assert done.returncode == 1 and done.stderr == "franka-sim: --from 5 is after --to 2\n"


def test_no_line_is_drawn_across_states_that_were_not_sent(lockstep_run):
    """A lockstep world settling after a motion sends only its first state and its last: the
    curves break between them rather than draw a straight line no state said."""
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from franka_sim.playback.plot import figure

    path, _ = lockstep_run
    recording = open_recording(path)
    ids = recording.states()["message_id"].astype(np.int64)
    gaps = int((np.diff(ids) > 1).sum())
    assert gaps > 0  # (the session's motions end, and the world settles unsent)
    fig = figure(recording, joints=[0, 3])
    for ax in fig.axes[:6]:  # q, dq, tau, wrench, success, the robot mode
        curves = [line for line in ax.get_lines() if len(line.get_xdata()) > 2
                  and (ax is not fig.axes[5] or line.get_drawstyle() == "steps-post")]
        assert curves  # (not only the motions' boundaries)
        for line in curves:
            x = np.asarray(line.get_xdata(), dtype=float)
            assert np.isnan(x).sum() == gaps
            runs = np.split(x, np.flatnonzero(np.isnan(x)))
            assert all(np.all(np.diff(run[np.isfinite(run)]) < 1.5e-3) for run in runs)
    plt.close(fig)


def test_a_recording_whose_first_robot_sent_nothing_plots_the_first_that_did(tmp_path):
    """Two arms, a client on the right one only: plot draws the right arm, unasked."""
    pytest.importorskip("matplotlib")
    from support.replayed import right_arm_only

    path = tmp_path / "r.mcap"
    with right_arm_only(path):
        pass
    recording = open_recording(path)
    assert not len(recording.states("left"))
    done = franka_sim("plot", str(path), "-o", str(tmp_path / "r.png"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "r.png").stat().st_size > 0
    from franka_sim.playback.plot import figure

    fig = figure(recording, joints=[0])
    assert fig.axes[0].get_title().endswith("states of right")  # (it says which it drew)
    import matplotlib.pyplot as plt

    plt.close(fig)
    asked = franka_sim("plot", str(path), "-o", str(tmp_path / "l.png"), "--robot", "left")
    assert asked.returncode == 1
    assert "robot 'left' sent no state (--robot right did)" in asked.stderr


def test_the_vacuum_grippers_panel_draws_its_vacuum_shaded_where_a_part_was_present():
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from franka_sim.playback.plot import _tool
    from franka_sim.protocol.codec import VACUUM_GRIPPER_STATE_DTYPE

    states = np.zeros(6, VACUUM_GRIPPER_STATE_DTYPE)
    states["message_id"] = [100, 200, 300, 400, 900, 1000]  # (none sent from 500 to 800)
    states["vacuum"] = [0, 300, 600, 600, 600, 0]
    states["part_present"] = [False, True, True, True, True, False]
    fig, ax = plt.subplots()
    _tool(ax, "vacuum_gripper_state", states, states["message_id"] * 1e-3)
    vacuum = ax.get_lines()[0].get_ydata()
    assert np.isnan(vacuum).sum() == 1 and np.nanmax(vacuum) == 600  # broken at the gap only
    assert [c.get_label() for c in ax.collections] == ["part_present"]
    assert ax.get_ylabel().startswith("vacuum")
    plt.close(fig)


def test_an_arm_that_trembles_plots_flat_at_its_values_not_its_tremble_at_full_scale():
    """A joint held still trembles by ~1e-9 rad (a grasped cube's contacts): matplotlib alone
    draws that at full scale, labelled with an offset; a panel shows at least its least span."""
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from franka_sim.playback.plot import LEAST_SPAN, _readable

    t = np.arange(200) * 1e-3
    held = 0.7853981634 + 1e-9 * np.sin(40 * t)
    fig, (alone, readable) = plt.subplots(2, 1)
    alone.plot(t, held)
    readable.plot(t, held)
    _readable(readable, LEAST_SPAN["q"])
    fig.canvas.draw()
    assert alone.yaxis.get_offset_text().get_text() != ""  # what a user saw: "+7.854e-1"
    assert readable.yaxis.get_offset_text().get_text() == ""
    low, high = readable.get_ylim()
    assert high - low == pytest.approx(LEAST_SPAN["q"]) and low < held[0] < high
    plt.close(fig)


def test_render_writes_the_expected_number_of_frames(lockstep_run, tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    path, _ = lockstep_run
    out = tmp_path / "run.mp4"
    done = franka_sim("render", str(path), "-o", str(out), "--fps", "10")
    if "no offscreen OpenGL" in done.stderr:
        pytest.skip(done.stderr.strip())
    assert done.returncode == 0, done.stderr
    ids = open_recording(path).states()["message_id"]
    expected = len(frame_cycles(int(ids[0]), int(ids[-1]), 10.0))
    assert done.stdout.strip() == f"{out}: {expected} frames"
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == expected
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (VIDEO_WIDTH, HEIGHT)
    first = np.frombuffer(next(reader), np.uint8)
    assert first.std() > 10  # a scene, not a blank frame


@pytest.mark.parametrize("args, message", [
    (["plot", "{rec}", "-o", "{tmp}/x.png", "--joints", "1,9"], "joints are numbered 1 to 7"),
    (["plot", "{rec}", "-o", "{tmp}/x.png", "--joints", "one"], "joint numbers 1-7"),
    (["plot", "{rec}", "-o", "{tmp}/x.png", "--fields", "q,qq"], "RobotState has no field 'qq'"),
    (["plot", "{rec}", "-o", "{tmp}/x.txt"], "{tmp}/x.txt: a plot is written as .jpeg, .jpg"),
    (["render", "{rec}", "-o", "{tmp}/x.mp4", "--camera", "nope"], "no such camera"),
    (["render", "{rec}", "-o", "{tmp}/x.gif"], "a video is .mp4, .mkv, .mov, .avi"),
    (["render", "{rec}", "-o", "{tmp}/no/x.mp4"], "cannot write {tmp}/no/x.mp4: no directory"),
])
def test_unknown_names_say_so_in_one_line(lockstep_run, tmp_path, args, message):
    path, _ = lockstep_run
    done = franka_sim(*[a.format(rec=path, tmp=tmp_path) for a in args])
    assert done.returncode == 1
    message = message.format(tmp=tmp_path)
    assert message in done.stderr and done.stderr.count("\n") == 1, done.stderr


@pytest.mark.parametrize("command", ["replay", "plot", "render"])
def test_truncated_foreign_and_incompatible_files(lockstep_run, tmp_path, command):
    path, _ = lockstep_run
    data = path.read_bytes()
    (tmp_path / "truncated.mcap").write_bytes(data[: len(data) // 2])
    (tmp_path / "foreign.mcap").write_bytes(b"PK\x03\x04 not a recording" * 10)
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(tmp_path / "other.mcap", "wb") as f:  # an MCAP file of another program
        writer = Writer(f)
        writer.start()
        writer.finish()
    with open(path, "rb") as f:  # 64 bytes of a chunk in the middle flipped
        chunks = make_reader(f).get_summary().chunk_indexes
    chunk = chunks[len(chunks) // 2]
    middle = chunk.chunk_start_offset + chunk.chunk_length // 2
    (tmp_path / "damaged.mcap").write_bytes(
        data[:middle] + bytes(b ^ 0xFF for b in data[middle:middle + 64]) + data[middle + 64:])
    (tmp_path / "head.mcap").write_bytes(data[:300])  # its magic and header, no whole record
    version = str(FORMAT_VERSION).encode()
    (tmp_path / "future.mcap").write_bytes(data.replace(b"format_version\x01\x00\x00\x00" + version,
                                                        b"format_version\x01\x00\x00\x009"))
    for name, edits in [("no_robots", {"robots": "[]"}), ("no_clock", {"clock": None}),
                        ("bad_q0", {"q0": "[1, 2]"}), ("bad_urdf", {"urdf": "<robot/>"})]:
        _with_metadata(path, tmp_path / f"{name}.mcap", edits)
    extra = {"replay": [], "plot": ["-o", str(tmp_path / "p.png")],
             "render": ["-o", str(tmp_path / "r.mp4")]}[command]
    for name, message in [("truncated", "truncated"), ("foreign", "not an MCAP file"),
                          ("other", "not a franka-sim recording"),
                          ("future", "recording format v9"),
                          ("damaged", "damaged, not as it was written"),
                          ("head", "truncated before its first complete record"),
                          ("no_robots", "its metadata is damaged: robots '[]' is not a list"),
                          ("no_clock", "its metadata is damaged: no clock"),
                          ("bad_q0", "its metadata is damaged: q0 '[1, 2]' is not 7 joint"),
                          *([("bad_urdf", "the recorded world cannot be built: missing "
                              "required joints")] if command == "replay" else [])]:
        done = franka_sim(command, str(tmp_path / f"{name}.mcap"), *extra)
        assert done.returncode == 1, (name, done.stdout, done.stderr)
        assert message in done.stderr and done.stderr.count("\n") == 1, (name, done.stderr)


def _with_metadata(source: Path, target: Path, edits: dict) -> None:
    """A copy of a recording whose franka-sim metadata has `edits` (None: the field left
    out), as a file damaged or edited by hand would have it."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(source, "rb") as given, open(target, "wb") as copy:
        reader = make_reader(given)
        summary = reader.get_summary()
        writer = Writer(copy)
        writer.start()
        schemas = {key: writer.register_schema(s.name, s.encoding, s.data)
                   for key, s in summary.schemas.items()}
        channels = {key: writer.register_channel(c.topic, c.message_encoding,
                                                 schemas.get(c.schema_id, 0), c.metadata)
                    for key, c in summary.channels.items()}
        for record in reader.iter_metadata():
            fields = {**record.metadata, **edits}
            writer.add_metadata(record.name, {k: v for k, v in fields.items() if v is not None})
        for _, channel, message in reader.iter_messages(log_time_order=False):
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time, message.sequence)
        writer.finish()


def test_an_unwritable_record_target_stops_serve_at_start(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "franka_sim", "serve", "--host", "127.0.0.1",
         "--record", str(tmp_path / "missing" / "run.mcap")],
        capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert done.stderr.strip().splitlines()[-1] == (
        f"franka-sim: cannot record to {tmp_path / 'missing' / 'run.mcap'}: "
        "No such file or directory")


def test_a_fifo_as_record_target_is_refused_without_waiting_for_a_reader(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host", "127.0.0.1",
                           "--record", str(fifo)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1] == (
        f"franka-sim: cannot record to {fifo}: a FIFO cannot take a recording (it is written "
        "with seeks)")


def test_a_start_refused_leaves_no_recording_behind(tmp_path):
    """The arms placed into each other: serve stops as it builds the world, and the file
    --record opened, which would hold nothing of a run, goes."""
    from franka_sim.testing import fresh_loopback_address

    left, right, out = fresh_loopback_address(), fresh_loopback_address(), tmp_path / "run.mcap"
    done = subprocess.run(
        [sys.executable, "-m", "franka_sim", "serve", "--arm", f"left={left}", "--arm",
         f"right={right}", "--record", str(out)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "arm left: placed into arm right" in done.stderr
    assert not out.exists()


def test_a_second_server_given_a_recording_under_way_is_refused_and_the_first_is_whole(
        tmp_path):
    """Two `serve --record run.mcap`: the second is refused before it touches the file (it
    emptied the first's recording, and removed it when its own start then failed). Read
    meanwhile, the file is said to be still recorded, not truncated."""
    from franka_sim.testing import ServerProcess, fresh_loopback_address

    out, host = tmp_path / "run.mcap", fresh_loopback_address()
    first = ServerProcess(host, "--clock", "lockstep", "--record", str(out)).wait_ready()
    try:
        for again in (host, fresh_loopback_address()):  # (its address in use, or another)
            done = subprocess.run(
                [sys.executable, "-m", "franka_sim", "serve", "--host", again, "--record",
                 str(out)], capture_output=True, text=True, timeout=60)
            assert done.returncode == 1
            assert done.stderr.strip().splitlines()[-1] == (
                f"franka-sim: cannot record to {out}: another process is recording to it")
        for command in (["replay"], ["plot", "-o", str(tmp_path / "p.png")]):  # (not "recover
            done = franka_sim(command[0], str(out), *command[1:])  # it": it has no end yet)
            assert done.returncode == 1 and done.stderr.count("\n") == 1, done.stderr
            assert f"{out}: still being recorded (" in done.stderr, done.stderr
    finally:
        first.stop()
    replayed = franka_sim("replay", str(out))
    assert replayed.returncode == 0 and replayed.stdout.startswith("identical"), replayed.stderr


def test_a_device_is_recorded_to_by_as_many_servers_as_ask():
    """/dev/null takes any number of recordings at once: only a file is locked."""
    from franka_sim.testing import ServerProcess, fresh_loopback_address

    servers = [ServerProcess(fresh_loopback_address(), "--record", "/dev/null").wait_ready()
               for _ in range(2)]
    try:  # and a start that fails (its address in use) leaves the device where it is
        done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                               servers[0].host, "--record", "/dev/null"],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 1 and "in use" in done.stderr
        assert Path("/dev/null").is_char_device()
    finally:
        for server in servers:
            server.stop()
            assert server.proc.returncode == 0, server.lines


def test_replay_until_before_the_first_state_says_that_is_why_nothing_was_compared(
        lockstep_run):
    path, _ = lockstep_run
    done = franka_sim("replay", str(path), "--until", "0")
    assert done.returncode == 0
    assert done.stdout.strip() == ("identical (0 cycles: no state was sent by cycle 0, so "
                                   "nothing was compared)")
