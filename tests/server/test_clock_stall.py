"""A realtime server the machine did not run for a while says so in its log: its robot's time
then runs slower than the wall clock, which no client can see (the states' time is the cycle
count). A stopped process stands in for a loaded machine: the same stall every run."""

from __future__ import annotations

import os
import signal
import time

from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.clients import connect


def test_a_realtime_clock_held_up_says_it_fell_behind_once():
    server = ServerProcess(fresh_loopback_address())
    try:
        server.wait_ready()
        robot = connect(server.host)
        robot.read_once()
        os.kill(server.pid, signal.SIGSTOP)
        time.sleep(0.3)
        os.kill(server.pid, signal.SIGCONT)
        robot.read_once()
        lines = server.wait_for_log("the realtime clock fell behind the wall clock")
        assert len(lines) == 1 and "(stall 1, " in lines[0]
        behind = float(lines[0].rsplit(", ", 1)[1].split(" s ")[0])
        assert 0.25 < behind < 10.0
    finally:
        server.stop()
