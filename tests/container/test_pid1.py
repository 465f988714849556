"""`franka-sim serve` as PID 1 of its own PID namespace, as in a container: SIGTERM stops it at
once whenever it comes, during start-up too (the kernel drops a signal that PID 1 has no
handler for, so without one `docker stop` waits out its 10 s and kills)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from franka_sim.testing import fresh_loopback_address


def _serve_as_pid1(host: str) -> tuple[subprocess.Popen, int]:
    """`unshare --pid --fork` running the server; returns it and the server's pid out here."""
    proc = subprocess.Popen(["unshare", "--pid", "--fork", "--mount-proc", sys.executable, "-m",
                             "franka_sim", "serve", "--host", host],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    children = f"/proc/{proc.pid}/task/{proc.pid}/children"
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.skip(f"no PID namespace here: {proc.stderr.read().strip()}")
        try:
            return proc, int(open(children).read().split()[0])
        except (IndexError, OSError):
            time.sleep(0.005)
    proc.kill()
    pytest.fail("unshare started no server")


def _namespace_pid(pid: int) -> str:
    status = open(f"/proc/{pid}/status").read()
    return status.split("NSpid:")[1].split("\n")[0].split()[-1]


@pytest.mark.parametrize("after", [0.3, 1.0, "serving"],
                         ids=["while-the-cli-starts", "while-the-server-loads", "serving"])
def test_sigterm_stops_it_as_pid1_at_any_moment(after):
    proc, server = _serve_as_pid1(fresh_loopback_address())
    try:
        assert _namespace_pid(server) == "1"
        if after == "serving":
            for line in proc.stderr:
                if "serving on" in line:
                    break
        else:
            time.sleep(after)
        start = time.perf_counter()
        os.kill(server, signal.SIGTERM)
        assert proc.wait(5) == 0
        assert time.perf_counter() - start < 2.0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
