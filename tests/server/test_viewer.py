"""`serve --viewer` on a real display (Xvfb): the window opens on the running world, shows the
arm move under a pylibfranka motion, and the server stops cleanly with it open."""

from __future__ import annotations

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.clients import connect, move_to
from support.xserver import wait_for_screen, xvfb


def test_the_viewer_shows_the_arm_move_and_stops_cleanly():
    with xvfb() as display:
        server = ServerProcess(fresh_loopback_address(), "--viewer", "--clock", "lockstep",
                               env={"DISPLAY": display}).wait_ready()
        try:
            before = wait_for_screen(display)  # the window, drawn
            robot = connect(server.host)
            target = np.array(READY_POSE) + [0.6, 0, 0, 0, 0, 0, 0]
            reached = move_to(robot, target, seconds=1.0)
            np.testing.assert_allclose(reached, target, atol=1e-2)
            wait_for_screen(display, changed_from=before)  # the arm turned on the screen
            assert Control(server.host).health()["ready"]
            assert not server.log_matching("failed")
        finally:
            took = server.stop()
        assert server.proc.returncode == 0, "\n".join(server.lines)
        assert took < 10
