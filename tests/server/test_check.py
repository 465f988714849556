"""`franka-sim check`: exit 0 when ready, else 1 and one line on stderr saying why."""

from __future__ import annotations

import socket
import subprocess
import sys
import time

from franka_sim.testing import ServerProcess, fresh_loopback_address, running_sim


def _check(*args: str, timeout: float = 60):
    done = subprocess.run([sys.executable, "-m", "franka_sim", "check", *args],
                          capture_output=True, text=True, timeout=timeout)
    return done.returncode, done.stderr


def _vacant_address() -> str:
    """A fresh loopback address where nothing listens (another test run on this machine may
    have a server on one of ours)."""
    while True:
        host = fresh_loopback_address()
        for port in (1337, 1340):
            try:
                socket.create_connection((host, port), timeout=1).close()
                break
            except OSError:
                pass
        else:
            return host


def _one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


def test_a_ready_simulator_passes_through_health_and_through_the_fci():
    with running_sim("--clock", "lockstep") as sim:
        assert _check(sim.host) == (0, "")
        assert _check(sim.host, "--fci") == (0, "")
        # The probe's client was a real one, and it left.
        assert sim.wait_for_log("FCI client") and sim.wait_for_log("disconnected")


def test_a_host_with_a_port_is_told_where_the_port_goes():
    code, stderr = _check("127.0.0.1:1340")
    assert code == 1
    assert _one_line(stderr) == ("franka-sim check: 127.0.0.1:1340: HOST is an address alone; "
                                 "the control API's port is --control-port")


def test_no_simulator_fails_on_one_line_saying_refused():
    host = _vacant_address()
    code, stderr = _check(host)
    assert code == 1
    line = _one_line(stderr)
    assert host in line and "refused" in line.lower()
    code, stderr = _check(host, "--fci")
    assert code == 1
    line = _one_line(stderr)
    assert f"{host}:1337" in line and "refused" in line.lower()


def test_a_wrong_token_is_unauthorized():
    with running_sim("--control-token", "s3cret") as sim:
        code, stderr = _check(sim.host, "--token", "guess")
        assert code == 1 and "unauthorized" in _one_line(stderr).lower()
        assert _check(sim.host, "--token", "s3cret") == (0, "")
        # no wait mends a wrong token: said at once, not after --wait's time
        started = time.monotonic()
        code, stderr = _check(sim.host, "--token", "guess", "--wait", "60")
        assert code == 1 and "unauthorized" in _one_line(stderr).lower()
        assert time.monotonic() - started < 30


def test_wait_polls_until_a_late_server_is_ready():
    host = _vacant_address()
    checker = subprocess.Popen([sys.executable, "-m", "franka_sim", "check", host,
                                "--wait", "120"], stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    assert checker.poll() is None  # still waiting: nothing serves there yet
    server = ServerProcess(host, "--clock", "lockstep")
    try:
        assert checker.wait(120) == 0, checker.stderr.read()
        assert server.serving_at is not None  # it passed once the server served
    finally:
        checker.stderr.close()
        server.stop()


def test_wait_gives_up_with_the_last_reason():
    t0 = time.monotonic()
    code, stderr = _check(_vacant_address(), "--wait", "1")
    assert code == 1 and "refused" in _one_line(stderr).lower()
    assert 1.0 <= time.monotonic() - t0 < 30


def test_a_listener_that_never_answers_is_a_timeout():
    host = _vacant_address()
    with socket.create_server((host, 1340)), socket.create_server((host, 1337)):
        code, stderr = _check(host, "--timeout", "0.5")
        assert code == 1 and "time" in _one_line(stderr).lower()
        code, stderr = _check(host, "--fci", "--timeout", "0.5")
        assert code == 1 and "no connect response" in _one_line(stderr).lower()
