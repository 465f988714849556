"""A run of the Hand alone (a gripper test, no arm client): its recording has no arm state, and
every tool still does what it can with it."""

from __future__ import annotations

import math
import subprocess
import sys

import pylibfranka
import pytest

from franka_sim.recording.reader import open_recording
from franka_sim.testing import running_sim


@pytest.fixture(scope="module")
def hand_only(tmp_path_factory):
    path = tmp_path_factory.mktemp("hand") / "hand.mcap"
    with running_sim("--record", str(path), "--clock", "lockstep") as sim:
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.homing() and gripper.move(0.04, 0.1)
        READ.append(gripper.read_once().width)
        assert gripper.grasp(0.0, 0.1, 20.0)  # closed on nothing: held at 0 within epsilon
        assert gripper.read_once().is_grasped
        del gripper
    return path


READ = []  # the width the client read after its move


def franka_sim(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "franka_sim", *args], capture_output=True,
                          text=True, timeout=300)


def test_replay_compares_the_hand_states(hand_only):
    recording = open_recording(hand_only)
    assert len(recording.states()) == 0
    sent = len(recording.of("gripper_state"))
    assert sent > 5
    done = franka_sim("replay", str(hand_only))
    assert done.returncode == 0
    assert done.stdout.strip() == f"identical (0 cycles, {sent} tool states)"


def test_plot_draws_the_hands_panel_alone(hand_only, tmp_path):
    """Its width as pylibfranka's Gripper read it, shaded where it held a grasp."""
    pytest.importorskip("matplotlib", reason="plot needs franka-sim[plot]")
    import matplotlib.pyplot as plt
    import numpy as np

    from franka_sim.playback.plot import figure

    fig = figure(open_recording(hand_only), joints=list(range(7)))
    (ax,) = fig.axes
    assert ax.get_ylabel() == "Hand width [m]" and "Hand states" in ax.get_title()
    width = ax.get_lines()[0].get_ydata()
    assert np.nanmax(width) > 0.07 and np.nanmin(width) < 1e-3  # open, then closed
    assert np.any(np.isclose(width, READ[0]))
    assert np.any(np.isfinite(width[1:]) & np.isfinite(width[:-1]))  # (lines between states)
    assert [c.get_label() for c in ax.collections] == ["is_grasped"]
    plt.close(fig)
    done = franka_sim("plot", str(hand_only), "-o", str(tmp_path / "h.png"))
    assert done.returncode == 0 and (tmp_path / "h.png").stat().st_size > 0, done.stderr
    done = franka_sim("plot", str(hand_only), "-o", str(tmp_path / "h.png"), "--fields", "elbow")
    assert done.returncode == 1
    assert done.stderr.strip() == "franka-sim: --fields: no arm state recorded (only its tool's)"


def test_the_viewers_timeline_spans_the_worlds_poses(hand_only):
    pytest.importorskip("viser", reason="the web view needs franka-sim[web] (viser)")
    from franka_sim.web.recording_view import timeline_of

    timeline = timeline_of(open_recording(hand_only))
    assert timeline.duration > 0.5  # the homing and the move, in robot time
    assert timeline.at(timeline.duration).states == (None,)  # no arm state to show


def test_render_draws_the_fingers_over_the_time_the_poses_span(hand_only, tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="render needs franka-sim[render]")
    done = franka_sim("render", str(hand_only), "-o", str(tmp_path / "h.mp4"), "--fps", "5")
    if "no offscreen OpenGL" in done.stderr:
        pytest.skip(done.stderr.strip())
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split(": ")[1].split()[0]) > 2  # (the homing and the move)


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_a_clients_request_during_a_homing_nobody_awaits_is_answered_and_replays(tmp_path,
                                                                                  clock):
    """The control API's homing (the Desk's) has no client to answer: a client's move or stop
    while it runs ends it and is answered itself, and the run replays."""
    from franka_sim.control import Control

    path = tmp_path / "homing.mcap"
    with running_sim("--record", str(path), "--clock", clock) as sim:
        control = Control(sim.host)
        gripper = pylibfranka.Gripper(sim.host)
        assert control.home_gripper() == {"homing": True}
        assert gripper.move(0.04, 0.1)
        assert control.home_gripper() == {"homing": True}
        assert gripper.stop()
        assert control.health()["tool_client_connected"]
        del gripper
    done = franka_sim("replay", str(path))
    assert done.returncode == 0 and done.stdout.startswith("identical ("), done.stderr


def test_render_and_view_span_a_hand_acting_after_the_arms_last_state(tmp_path):
    """An arm's program, then a Hand's alone: the world drawn spans the Hand's actions too."""
    from franka_sim.assembly import WorldParts
    from franka_sim.playback.recorded_world import RecordedWorld
    from franka_sim.recording.metadata import replay_config
    from support.clients import connect, move_to

    path = tmp_path / "arm_then_hand.mcap"
    with running_sim("--record", str(path), "--clock", "lockstep") as sim:
        robot = connect(sim.host)
        q = list(robot.read_once().q)
        q[6] += 0.1
        move_to(robot, q, 0.3)
        del robot  # (its program ends: no arm state after it)
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.move(0.02, 0.1)
        del gripper
    recording = open_recording(path)
    last_arm_state = int(recording.states()["message_id"][-1])
    _, hand = recording.tool_states()
    assert hand["message_id"][-1] > last_arm_state + 300  # (the move took ~0.6 s)
    physics = WorldParts(replay_config(recording.metadata, str(tmp_path))).make_physics()
    world = RecordedWorld(recording, physics)
    assert world.last >= hand["message_id"][-1] - 10  # (poses at 100 Hz)
    # plot: a window of the Hand's alone draws its panel; a field of the arm's has none there
    pytest.importorskip("matplotlib", reason="plot needs franka-sim[plot]")
    window = ["--from", f"{(last_arm_state + 50) / 1000}", "-o", str(tmp_path / "w.png")]
    assert franka_sim("plot", str(path), *window).returncode == 0
    done = franka_sim("plot", str(path), *window, "--fields", "elbow")
    assert done.returncode == 1 and done.stderr.strip() == (
        "franka-sim: --fields: no arm state in the window --from/--to (only its tool's)")


def test_a_hostile_request_is_recorded_as_strict_json(tmp_path):
    """A Move whose width is NaN and a Grasp whose force is infinite (answered kFail): the
    recording's decoded requests spell them as strings, so a strict JSON reader (Foxglove's)
    opens every message, and replay still compares identical."""
    import json
    import socket
    import struct

    def strict(constant):
        raise ValueError(f"{constant} is not JSON")

    path = tmp_path / "hostile.mcap"
    with running_sim("--record", str(path), "--clock", "lockstep") as sim:
        with socket.create_connection((sim.host, 1338), timeout=20) as s:
            s.sendall(struct.pack("<HIIHH", 0, 1, 14, 3, 0))
            s.sendall(struct.pack("<HIIdd", 3, 2, 26, math.nan, 0.1))
            s.sendall(struct.pack("<HIIddddd", 2, 3, 50, 0.02, 0.005, 0.005, 0.1, math.inf))
            replies = b""
            while len(replies) < 14 + 12 + 12:
                replies += s.recv(64)
    assert struct.unpack("<HIIH", replies[14:26])[3] == 1  # kFail
    decoded = [json.loads(entry.data, parse_constant=strict)
               for entry in open_recording(path).of("tcp")]
    requests = [r for event in decoded for r in event.get("requests", [])]
    assert {"width": "NaN"}.items() <= requests[1].items()
    assert {"force": "Infinity"}.items() <= requests[2].items()
    done = franka_sim("replay", str(path))
    assert done.returncode == 0 and done.stdout.startswith("identical"), done.stdout


def test_a_recording_no_client_was_sent_a_state_in_says_nothing_was_compared(tmp_path):
    """Only control API changes recorded: replay does not claim to have checked them."""
    from franka_sim.control import Control

    path = tmp_path / "api.mcap"
    with running_sim("--record", str(path), "--clock", "lockstep") as sim:
        Control(sim.host).push("link7", force=[0.0, 10.0, 0.0], duration=0.1)
    done = franka_sim("replay", str(path))
    assert done.returncode == 0
    assert done.stdout.strip() == ("identical (0 cycles: no client was sent a state, so nothing "
                                   "was compared)")
