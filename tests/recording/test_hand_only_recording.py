"""A run of the Hand alone (a gripper test, no arm client): its recording has no arm state, and
every tool still does what it can with it."""

from __future__ import annotations

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
        del gripper
    return path


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


def test_plot_says_there_is_no_arm_state(hand_only, tmp_path):
    pytest.importorskip("matplotlib", reason="plot needs franka-sim[plot]")
    done = franka_sim("plot", str(hand_only), "-o", str(tmp_path / "h.png"))
    assert done.returncode == 1
    assert done.stderr.strip() == "franka-sim: no arm state recorded: nothing to plot"


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
