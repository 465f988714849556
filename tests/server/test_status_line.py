"""`franka-sim serve`'s live status line: on a terminal, one line rewritten in place; nothing
when stdout is not a terminal. And --viewer without a display: one clear line."""

from __future__ import annotations

import os
import pty
import select
import signal
import subprocess
import sys
import time

from franka_sim.testing import fresh_loopback_address


def _serve(stdout, *args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "franka_sim", "serve", "--host", fresh_loopback_address(),
         "--control-port", "0", *args],
        stdin=subprocess.DEVNULL, stdout=stdout, stderr=subprocess.DEVNULL)


def test_on_a_terminal_one_line_with_mode_rate_and_success():
    master, slave = pty.openpty()
    proc = _serve(slave)
    os.close(slave)
    out = b""
    try:
        end = time.monotonic() + 30
        while time.monotonic() < end and out.count(b"cycles/s") < 2:
            if select.select([master], [], [], 0.5)[0]:
                out += os.read(master, 4096)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
        os.close(master)
    text = out.decode(errors="replace")
    assert text.count("cycles/s") >= 2 and "\r\x1b[K" in text, text
    line = text.rsplit("\r\x1b[K", 1)[1]
    assert "client none" in line and "mode Idle" in line and "success" in line
    assert "last error: -" in line


def test_a_log_line_on_the_same_terminal_starts_on_a_line_of_its_own():
    """stdout and stderr on one terminal (`docker run -t`): a record clears the status line
    first rather than running on from it."""
    master, slave = pty.openpty()
    host = fresh_loopback_address()
    proc = subprocess.Popen([sys.executable, "-m", "franka_sim", "serve", "--host", host],
                            stdin=subprocess.DEVNULL, stdout=slave, stderr=slave)
    os.close(slave)
    out, asked = b"", False
    try:
        end = time.monotonic() + 60
        while time.monotonic() < end and b"GET /nothing refused" not in out:
            if select.select([master], [], [], 0.2)[0]:
                out += os.read(master, 4096)
            if not asked and b"cycles/s" in out:
                asked = True
                _get(host, "/nothing")  # (one log line: the refusal)
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
        os.close(master)
    text = out.decode(errors="replace")
    before = text[:text.index("control API: GET /nothing")]
    record = before[before.rindex("\r\x1b[K") + len("\r\x1b[K"):]
    assert record.startswith("20") and "cycles/s" not in record, repr(before[-300:])


def _get(host: str, path: str) -> None:
    import urllib.error
    import urllib.request

    try:
        urllib.request.urlopen(f"http://{host}:1340{path}", timeout=30)
    except urllib.error.HTTPError:
        pass


def test_not_a_terminal_no_status():
    proc = _serve(subprocess.PIPE)
    time.sleep(2.0)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=10)
    assert out == b""


def test_viewer_without_a_display_says_so():
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--viewer"],
                          capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip() == ("franka-sim: --viewer needs a display (DISPLAY is not set); "
                                   "`franka-sim render` makes a video without one")
