"""Shared fixtures: a live simulated robot per test, each on its own loopback address.

The simulator runs as a real `franka-sim serve` subprocess: pylibfranka's blocking calls hold
the GIL, so a server thread in the test process would starve while the client waits for it.
Addresses come from 127.<pid-derived>.<n>.<m>, never 127.0.0.1, so tests do not collide with
each other, with a concurrent pytest run, or with a `franka-sim serve` left on the default.
"""

from __future__ import annotations

import itertools
import os
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager

import numpy as np
import pytest

_counter = itertools.count()


def fresh_loopback_address() -> str:
    n = next(_counter)
    return f"127.{20 + os.getpid() % 200}.{n // 250}.{n % 250 + 2}"


class ServerProcess:
    """`franka-sim serve` in a subprocess; its log lines are collected for assertions."""

    def __init__(self, host: str, *args: str, env: dict | None = None) -> None:
        self.host = host
        self.lines: list[str] = []
        self._ready = threading.Event()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "franka_sim", "serve", "--host", host, *args],
            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
            env={**os.environ, **(env or {})},
        )
        self._reader = threading.Thread(target=self._drain, daemon=True)
        self._reader.start()

    def _drain(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))
            if "serving on" in line:
                self._ready.set()
        self._ready.set()

    def wait_ready(self, timeout: float = 60.0) -> "ServerProcess":
        if not self._ready.wait(timeout) or self.proc.poll() is not None:
            self.stop()
            raise RuntimeError("franka-sim did not start:\n" + "\n".join(self.lines))
        return self

    def log_matching(self, text: str) -> list[str]:
        return [line for line in self.lines if text in line]

    def wait_for_log(self, text: str, timeout: float = 10.0) -> list[str]:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            found = self.log_matching(text)
            if found:
                return found
            time.sleep(0.01)
        return []

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(2)
        return self.proc.returncode


@contextmanager
def running_sim(*args: str, host: str | None = None, env: dict | None = None):
    server = ServerProcess(host or fresh_loopback_address(), *args, env=env).wait_ready()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def sim():
    with running_sim() as s:
        yield s


@pytest.fixture
def robot(sim):
    """A pylibfranka Robot connected to a fresh simulator, as client code would make it."""
    import pylibfranka

    return pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)


@pytest.fixture(scope="session")
def description():
    from franka_sim.description.urdf import default_urdf_text, load_arm_description

    return load_arm_description(default_urdf_text())


@pytest.fixture(scope="session")
def physics(description):
    """The simulator's own physics, built exactly as the server builds it, for comparisons."""
    from franka_sim.config import READY_POSE
    from franka_sim.physics.mujoco_backend import MujocoBackend

    return MujocoBackend(description, np.array(READY_POSE))
