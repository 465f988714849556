"""`franka-sim serve` as a subprocess, for tests and benchmarks.

A subprocess, not a thread: pylibfranka's blocking calls hold the GIL, so a server in the
client's process would starve while the client waits for it. Its log lines are collected for
assertions, and "serving on" is the moment it accepts clients.
"""

from __future__ import annotations

import itertools
import os
import select
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager

_counter = itertools.count()


def fresh_loopback_address() -> str:
    """A loopback address of its own (127.<pid-derived>.<n>.<m>, never 127.0.0.1): servers do
    not collide with each other, with a concurrent run, or with a server left on the default."""
    n = next(_counter)
    return f"127.{20 + os.getpid() % 200}.{n // 250}.{n % 250 + 2}"


def _normal_scheduling() -> None:
    """In the child, before exec: ordinary scheduling. libfranka raises the thread that starts
    a control loop to SCHED_FIFO 99 (as root, it can), and a child inherits that: a server
    started later from the same test process would run at the highest real-time priority and
    could starve the machine. `franka-sim serve --rt-priority N` still sets its own."""
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError):  # not Linux, or not allowed: keep what we have
        pass


def _dying_with(parent: int):
    """In the child, before exec: ordinary scheduling (above), and SIGTERM should `parent` die
    (a test run killed outright, SIGKILL or SIGTERM, leaves no server behind; Linux's
    PR_SET_PDEATHSIG, kept across exec)."""
    def prepare() -> None:
        _normal_scheduling()
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM, 0, 0, 0)  # SET_PDEATHSIG
        except (OSError, AttributeError):  # not Linux
            return
        if os.getppid() != parent:  # (it died before the prctl: nobody would signal)
            os._exit(1)
    return prepare


class ServerProcess:
    """`python -m franka_sim serve --host H *args` (or another `command` that logs `ready`,
    "serving on", to stderr, such as a benchmark's reference server or another simulator); a
    thread collects its stderr lines."""

    def __init__(self, host: str, *args: str, env: dict | None = None,
                 command: list[str] | None = None, ready: str = "serving on",
                 cwd: str | os.PathLike | None = None, die_with_parent: bool = False) -> None:
        self.host, self.ready = host, ready
        self.lines: list[str] = []
        self.serving_at: float | None = None  # perf_counter() when "serving on" was read
        self._ready = threading.Event()
        self.spawned_at = time.perf_counter()
        self.proc = subprocess.Popen(
            command or [sys.executable, "-P", "-m", "franka_sim", "serve", "--host", host, *args],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            env={k: v for k, v in {**os.environ, **(env or {})}.items() if v is not None},
            preexec_fn=_dying_with(os.getpid()) if die_with_parent else _normal_scheduling,
            cwd=cwd,
        )
        self.pid = self.proc.pid
        self._fd = self.proc.stderr.fileno()
        os.set_blocking(self._fd, False)
        self._lock = threading.Lock()  # one reader of the pipe at a time: the thread or sync()
        self._partial = b""  # a line's start whose end has not arrived
        self._eof = False
        self._reader = threading.Thread(target=self._drain, daemon=True)
        self._reader.start()

    def _drain(self) -> None:
        """Keep the pipe read (a full one would block the server's logging)."""
        while not self._eof:
            select.select([self._fd], [], [])
            with self._lock:
                self._read_available()
        self._ready.set()  # EOF: it exited, maybe before serving

    def sync(self) -> list[str]:
        """Every line the server has written so far, read now: a line it logged before the
        reply a client just received is here (the thread alone might not have read it yet)."""
        with self._lock:
            self._read_available()
        return self.lines

    def _read_available(self) -> None:
        while not self._eof:
            try:
                chunk = os.read(self._fd, 65536)
            except BlockingIOError:
                return
            if not chunk:
                self._eof = True
                chunk = b"\n" if self._partial else b""
            *complete, self._partial = (self._partial + chunk).split(b"\n")
            for raw in complete:
                self._take(raw.decode(errors="replace"))

    def _take(self, line: str) -> None:
        serving = self.serving_at is None and self.ready in line
        if serving:
            self.serving_at = time.perf_counter()
        self.lines.append(line)
        if serving:
            self._ready.set()

    def wait_ready(self, timeout: float = 60.0) -> ServerProcess:
        """Wait for "serving on"; stop it and raise with its log if that does not come."""
        ready = self._ready.wait(timeout) and self.serving_at is not None
        if not ready or self.proc.poll() is not None:
            self.stop()
            raise RuntimeError("franka-sim did not start:\n" + "\n".join(self.lines))
        return self

    @property
    def serving_after(self) -> float:
        """Seconds from spawn to the "serving on" line."""
        assert self.serving_at is not None, "not serving yet"
        return self.serving_at - self.spawned_at

    def log_matching(self, text: str) -> list[str]:
        return [line for line in self.sync() if text in line]

    def wait_for_log(self, text: str, timeout: float = 10.0) -> list[str]:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            found = self.log_matching(text)
            if found:
                return found
            time.sleep(0.01)
        return []

    def stop(self, timeout: float = 10.0) -> float:
        """SIGTERM and wait for the exit: the seconds that took (inf when it had to be killed
        after `timeout`; 0 when it had already exited)."""
        if self.proc.poll() is not None:
            took = 0.0
        else:
            # A blocking wait: Popen.wait(timeout) polls with growing sleeps and would quantise
            # the time it took.
            watchdog = threading.Timer(timeout, self.proc.kill)
            watchdog.start()
            t0 = time.perf_counter()
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait()
            took = time.perf_counter() - t0
            watchdog.cancel()
            if self.proc.returncode == -signal.SIGKILL:
                took = float("inf")
        self._reader.join(2)
        return took


@contextmanager
def running_sim(*args: str, host: str | None = None, env: dict | None = None):
    """A served robot on a fresh loopback address for the `with` block."""
    server = ServerProcess(host or fresh_loopback_address(), *args, env=env).wait_ready()
    try:
        yield server
    finally:
        server.stop()
