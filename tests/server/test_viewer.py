"""`serve --viewer` on a real display (Xvfb): the window opens on the running world, shows the
arm move under a pylibfranka motion, and the server stops cleanly with it open; a display that
cannot be opened ends the server with one line saying why."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.clients import connect, move_to
from support.xserver import opengl_display, wait_for_screen


def test_the_viewer_shows_the_arm_move_and_stops_cleanly():
    with opengl_display() as display:
        server = ServerProcess(fresh_loopback_address(), "--viewer", "--clock", "lockstep",
                               env={"DISPLAY": display}).wait_ready()
        try:
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


def test_a_display_that_does_not_answer_ends_the_server_saying_so():
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--viewer", "--host",
                           fresh_loopback_address()], capture_output=True, text=True,
                          env={**os.environ, "DISPLAY": ":4242"}, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1] == (
        "franka-sim: the viewer cannot open: X11: Failed to open display :4242")
