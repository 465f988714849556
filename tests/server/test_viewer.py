"""`serve --viewer` on a real display (Xvfb): the window opens on the running world, shows the
arm move under a pylibfranka motion, and the server stops cleanly with it open; a display that
cannot be opened ends the server with one line saying why; a display lost while the window is
up ends the viewer, not the robot."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.clients import connect, move_to
from support.xserver import SERVERS, opengl_display, screenshot, wait_for_screen


def test_the_viewer_shows_the_arm_move_and_stops_cleanly():
    with opengl_display() as display:
        server = ServerProcess(fresh_loopback_address(), "--viewer", "--clock", "lockstep",
                               env={"DISPLAY": display}).wait_ready()
        try:
            assert server.wait_for_log("the viewer shows the world", timeout=60)
            viewer = [child for task in Path(f"/proc/{server.pid}/task").iterdir()
                      for child in (task / "children").read_text().split()]
            assert len(viewer) == 1  # the window's own process
            maps = Path(f"/proc/{server.pid}/maps").read_text()
            assert "glfw" not in maps and "mujoco/_render" not in maps  # (the server draws not)
            before = wait_for_screen(display, server=server)  # the window, drawn
            robot = connect(server.host)
            target = np.array(READY_POSE) + [0.6, 0, 0, 0, 0, 0, 0]
            reached = move_to(robot, target, seconds=1.0)
            np.testing.assert_allclose(reached, target, atol=1e-2)
            wait_for_screen(display, changed_from=before, server=server)  # the arm turned on the screen
            assert Control(server.host).health()["ready"]
            assert not server.log_matching("failed")
        finally:
            took = server.stop()
        assert server.proc.returncode == 0, "\n".join(server.lines)
        assert took < 10
        assert not Path(f"/proc/{viewer[0]}").exists()  # it closed with the server


def test_a_display_that_does_not_answer_ends_the_server_saying_so():
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--viewer", "--host",
                           fresh_loopback_address()], capture_output=True, text=True,
                          env={**os.environ, "DISPLAY": ":4242"}, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1] == (
        "franka-sim: the viewer cannot open: X11: Failed to open display :4242")


def test_a_lost_display_ends_the_viewer_and_the_robot_serves_on():
    with opengl_display() as display:
        server = ServerProcess(fresh_loopback_address(), "--viewer", "--clock", "lockstep",
                               env={"DISPLAY": display}).wait_ready()
        try:
            assert server.wait_for_log("the viewer shows the world", timeout=60)
            wait_for_screen(display, server=server)
            SERVERS[display].kill()  # the X server gone, as with a dropped `ssh -X`
            SERVERS[display].wait(10)
            ended = server.wait_for_log("the viewer ended", timeout=30)
            assert ended and "serving goes on" in ended[0], "\n".join(server.lines)
            robot = connect(server.host)
            target = np.array(READY_POSE) + [0, 0, 0, 0, 0, 0, 0.5]
            np.testing.assert_allclose(move_to(robot, target, seconds=0.5), target, atol=1e-2)
            assert Control(server.host).health()["ready"]
        finally:
            server.stop()
        assert server.proc.returncode == 0, "\n".join(server.lines)


def test_the_viewer_shows_the_mobile_base_drive():
    """The base is a mocap body: its pose travels to the viewer with the world's qpos."""
    base_program = Path(__file__).resolve().parents[1] / "mobile" / "base_program.py"
    base, left, right = (fresh_loopback_address() for _ in range(3))
    with opengl_display() as display:
        server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                               f"right={right}", "--mobile-base", base, "--viewer", "--clock",
                               "lockstep", env={"DISPLAY": display}).wait_ready()
        try:
            assert server.wait_for_log("the viewer shows the world", timeout=60)
            before = _still(display, server)
            # It opens on the arms (their white links), as the web view does: MuJoCo's own
            # free camera framed the base's dark column from up close.
            white = (before.min(axis=2) > 190) & (np.ptp(before, axis=2) < 25)
            assert white.sum() > 3000, white.sum()
            done = subprocess.run([sys.executable, str(base_program), base, "0.4", "0.0", "0.0",
                                   "2.0"], capture_output=True, text=True, timeout=120)
            assert done.returncode == 0, done.stderr
            after = _still(display, server)
            moved = (np.abs(before.astype(int) - after.astype(int)).max(axis=2) > 40).sum()
            assert moved > 2000, moved  # (the chassis drove out of its place on the screen)
        finally:
            server.stop()


def _still(display: str, server, timeout: float = 60.0):
    """The screen once the world is drawn (not MuJoCo's black "LOADING…" screen) and unchanged
    over half a second (the viewer has drawn the world as it stands)."""
    deadline = time.monotonic() + timeout
    shot = wait_for_screen(display, server=server)
    while True:
        time.sleep(0.5)
        again = screenshot(display)
        if np.array_equal(shot, again) and shot.mean() > 10:  # ("LOADING…": ~0.2)
            return shot
        assert time.monotonic() < deadline, "the screen does not settle"
        shot = again


def test_a_stop_while_the_window_opens_stops_cleanly_and_keeps_the_recording(tmp_path):
    """The robot serves while the viewer's window opens: a SIGTERM meanwhile is a clean stop
    (exit 0, the recording whole), not a start cut short."""
    path = tmp_path / "run.mcap"
    with opengl_display() as display:
        server = ServerProcess(fresh_loopback_address(), "--viewer", "--clock", "lockstep",
                               "--record", str(path), env={"DISPLAY": display}).wait_ready()
        server.stop()  # (at "serving on": the window is most likely still opening)
        assert not _viewers_on(display)
    assert server.proc.returncode == 0, "\n".join(server.lines)
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=120)
    assert "truncated" not in done.stderr, done.stderr


def _viewers_on(display: str) -> list[int]:
    """Viewer processes drawing on `display` (this test's own X server): one left behind.
    (Any viewer on the machine would count another test's, or another user's.)"""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if (b"franka_sim.server.viewer" in (entry / "cmdline").read_bytes()
                        and f"DISPLAY={display}".encode()
                        in (entry / "environ").read_bytes().split(b"\0")):
                    found.append(int(entry.name))
            except OSError:
                pass
    return found
