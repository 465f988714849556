"""FRANKA_SIM_SERVING_FILE: `serve` writes what it serves there, and `franka-sim check` without a
HOST checks every robot it lists, as a container's health check does (it cannot see `serve`'s
flags)."""

from __future__ import annotations

import json
import os
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

from franka_sim.server.serving_file import Served, Serving, read, write
from franka_sim.testing import ServerProcess, fresh_loopback_address, running_sim


def _vacant_address() -> str:
    """A fresh loopback address where no control API listens."""
    while True:
        host = fresh_loopback_address()
        try:
            socket.create_connection((host, 1340), timeout=1).close()
        except OSError:
            return host


def _one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def _check(*args: str, env: dict[str, str]) -> tuple[int, str]:
    """`franka-sim check` with the image's environment (FRANKA_SIM_HOST=0.0.0.0) and `env`."""
    clean = {k: v for k, v in os.environ.items() if not k.startswith("FRANKA_SIM_")}
    done = subprocess.run([sys.executable, "-m", "franka_sim", "check", *args],
                          env={**clean, "FRANKA_SIM_HOST": "0.0.0.0", **env},
                          capture_output=True, text=True, timeout=180)
    return done.returncode, done.stderr


def test_serve_lists_every_robot_and_check_asks_them_all_until_it_stops(tmp_path):
    left, right, base = (fresh_loopback_address() for _ in range(3))
    path = tmp_path / "serving.json"
    # flags the health check cannot see: the robots' addresses, the port, the token
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                           f"right={right}", "--mobile-base", base, "--control-port", "1341",
                           "--control-token", "s3cret",
                           env={"FRANKA_SIM_SERVING_FILE": str(path)})
    try:
        server.wait_ready()
        env = {"FRANKA_SIM_SERVING_FILE": str(path)}
        assert _check("--wait", "120", env=env) == (0, "")
        listed = json.loads(path.read_text())
        assert [(r["name"], r["host"], r["control_port"]) for r in listed["robots"]] == [
            ("left", left, 1341), ("right", right, 1341), ("base", base, 1341)]
        assert stat.S_IMODE(path.stat().st_mode) == 0o600  # it holds the token
        # An address on the command line is checked instead, as without the file.
        code, stderr = _check(left, env=env)
        assert code == 1 and f"{left}:1340" in _one_line(stderr)
    finally:
        server.stop()
    assert not path.exists()
    code, stderr = _check(env={"FRANKA_SIM_SERVING_FILE": str(path)})
    assert code == 1 and "absent" in _one_line(stderr)


def test_check_names_the_first_robot_that_is_not_ready(tmp_path):
    path, vacant = tmp_path / "serving.json", _vacant_address()
    with running_sim("--clock", "lockstep") as sim:
        write(path, Serving((Served("left", sim.host, 1340), Served("right", vacant, 1340)),
                            None, os.getpid()))
        code, stderr = _check(env={"FRANKA_SIM_SERVING_FILE": str(path)})
        line = _one_line(stderr)
        assert code == 1 and line.startswith("franka-sim check: right: ") and vacant in line
        # a robot without a control API is ready once listed: it listens when the file is written
        write(path, Serving((Served("left", sim.host, 1340), Served("right", vacant, 0)),
                            None, os.getpid()))
        assert _check(env={"FRANKA_SIM_SERVING_FILE": str(path)}) == (0, "")


def test_a_file_its_server_left_behind_is_not_ready(tmp_path):
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    pid = int(gone.stdout)
    path = tmp_path / "serving.json"
    write(path, Serving((Served("fr3", "127.0.0.1", 0),), None, pid))
    code, stderr = _check(env={"FRANKA_SIM_SERVING_FILE": str(path)})
    assert code == 1 and f"pid {pid}" in _one_line(stderr)


def test_an_unwritable_serving_file_leaves_the_server_serving(tmp_path):
    path = Path(tmp_path / "no-such-folder" / "serving.json")
    with running_sim("--clock", "lockstep", env={"FRANKA_SIM_SERVING_FILE": str(path)}) as sim:
        assert sim.wait_for_log(f"cannot write FRANKA_SIM_SERVING_FILE={path}")
        assert _check(sim.host, env={}) == (0, "")


def test_a_server_stopping_leaves_another_servers_file(tmp_path):
    """Two servers given one path: the file is the last one's, and the first, stopping, does
    not take it away."""
    path = tmp_path / "serving.json"
    env = {"FRANKA_SIM_SERVING_FILE": str(path)}
    with running_sim("--clock", "lockstep", env=env) as first:
        with running_sim("--clock", "lockstep", env=env) as second:
            deadline = time.monotonic() + 30
            while read(path).pid != second.pid:
                assert time.monotonic() < deadline, "the second server's file never came"
                time.sleep(0.05)
            first.stop()
            assert read(path).pid == second.pid
            assert _check(env=env) == (0, "")
