"""`serve --web` as a user meets it without a browser: the extra missing said on one line, a
port in use refused at start, and bad requests to the web port answered or dropped in one log
line each while the robot and the page go on."""

from __future__ import annotations

import socket
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from franka_sim.control import Control
from franka_sim.testing import fresh_loopback_address, running_sim

WEB_PORT = 8080


def serve(host: str, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host", host, *args],
                          capture_output=True, text=True, timeout=120, env=env)


def test_without_the_extra_web_says_on_one_line_what_to_install(tmp_path):
    (tmp_path / "sitecustomize.py").write_text("import sys\nsys.modules['viser'] = None\n")
    import os

    env = {**os.environ, "PYTHONPATH": str(tmp_path), "FRANKA_SIM_WEB_PORT": str(WEB_PORT)}
    done = serve(fresh_loopback_address(), env=env)
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert lines == ["franka-sim: --web: the web view needs viser: pip install "
                     "'franka-sim[web]'"], done.stderr


def test_a_web_port_in_use_refuses_the_start():
    pytest.importorskip("viser")
    host = fresh_loopback_address()
    with socket.create_server((host, WEB_PORT)):
        done = serve(host, "--web", str(WEB_PORT))
    assert done.returncode == 1
    assert f"the web view's port {WEB_PORT} on {host} is in use" in done.stderr
    assert "Traceback" not in done.stderr


def _raw(host: str, data: bytes) -> bytes:
    with socket.create_connection((host, WEB_PORT), timeout=10) as sock:
        sock.sendall(data)
        sock.shutdown(socket.SHUT_WR)  # all there is: the server answers or drops it now
        chunks = []
        try:
            while chunk := sock.recv(4096):
                chunks.append(chunk)
        except (TimeoutError, ConnectionResetError):
            pass
    return b"".join(chunks)


def test_bad_requests_are_answered_4xx_or_dropped_and_serving_goes_on():
    pytest.importorskip("viser")
    with running_sim("--web", str(WEB_PORT)) as server:
        base = f"http://{server.host}:{WEB_PORT}"
        with pytest.raises(urllib.error.HTTPError) as missing:
            urllib.request.urlopen(f"{base}/../../etc/passwd", timeout=10)
        assert missing.value.code == 404
        # a connection closed unused (a browser's spare one as its page closes): no line
        socket.create_connection((server.host, WEB_PORT), timeout=10).close()
        # junk, a TLS hello in clear, a WebSocket upgrade without its key
        for junk in (b"NOT HTTP AT ALL\r\n\r\n", b"\x16\x03\x01\x02\x00" + bytes(300),
                     b"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\n"
                     b"Connection: Upgrade\r\n\r\n"):
            answer = _raw(server.host, junk)
            assert answer == b"" or answer.startswith(b"HTTP/1.1 4"), answer[:80]
        with urllib.request.urlopen(f"{base}/", timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read(2000).lower()
        assert Control(server.host).state()["robot_mode"] == "Idle"
        log = server.sync()
        assert not any("Traceback" in line for line in log), "\n".join(log)
        # each junk request has its line, naming what was wrong; the unused connection none
        failed = server.log_matching("web view: opening handshake failed")
        assert len(failed) == 3 and not [line for line in failed if "EOFError" in line], failed
        # the mistyped page has its line, naming it; the pages served have none
        assert len(server.log_matching("web view: /../../etc/passwd: 404")) == 1, "\n".join(log)
        assert not server.log_matching("connection rejected (200")
        assert server.proc.poll() is None


def test_view_says_on_one_line_what_it_cannot_show(tmp_path):
    pytest.importorskip("viser")
    junk = tmp_path / "junk.mcap"
    junk.write_text("junk")
    host = fresh_loopback_address()
    recording = (Path(__file__).resolve().parents[1] / "data" / "older_libfranka" / "0.13.6"
                 / "communication_test.mcap")
    with socket.create_server((host, WEB_PORT)):
        cases = {"No such file": [str(tmp_path / "missing.mcap")],
                 "not an MCAP file": [str(junk)],
                 f"port {WEB_PORT} on {host} is in use": [str(recording), "--host", host,
                                                          "--port", str(WEB_PORT)],
                 # (viser alone would try the next thousand ports, saying nothing)
                 "999.1.1.1:8080 cannot be served": [str(recording), "--host", "999.1.1.1"]}
        for said, args in cases.items():
            done = subprocess.run([sys.executable, "-m", "franka_sim", "view", *args],
                                  capture_output=True, text=True, timeout=120)
            assert done.returncode == 1
            assert done.stderr.count("\n") == 1 and said in done.stderr, done.stderr
