"""Shared helpers for the benchmarks: the reference servers' commands, /proc readings, the
machine's load. The server process and the raw v10 client are franka_sim.testing's.

Not a benchmark itself. Everything here uses only the standard library.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import time
from pathlib import Path

PRIVATE_HOST = "127.0.0.200"
CLK_TCK = os.sysconf("SC_CLK_TCK")


def reference_command(host: str) -> list[str]:
    """benchmarks/reference_sender.py: a trivial 1 kHz sender, the platform's floor."""
    return [sys.executable, str(Path(__file__).with_name("reference_sender.py")), "--host", host]


def reference_process() -> None:
    """Set up a reference server process as franka-sim sets up its own: SIGTERM exits, and a
    1 ns timer slack (PR_SET_TIMERSLACK) makes its sleeps precise."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    try:
        ctypes.CDLL(None).prctl(29, 1, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def responder_command(host: str, clock: str, physics: bool = False) -> list[str]:
    """benchmarks/reference_responder.py: a control loop's server doing nothing but the protocol
    (with `physics`, also the stripped torque cycle)."""
    return [sys.executable, str(Path(__file__).with_name("reference_responder.py")),
            "--host", host, "--clock", clock] + (["--physics"] if physics else [])


# What franka-sim 1.1.7 logs once it takes a client (docs/benchmarks.md, "Beside franka-sim 1.1.7").
ALTERNATIVE_READY = "ready for new client connection"


def start_server(host: str, alternative: str | None = None, *args: str):
    """`franka-sim serve --host host *args`, or with `alternative` that simulator's command
    line ("{host}": the address), started and serving (franka_sim.testing.ServerProcess)."""
    import shlex

    from franka_sim.testing import ServerProcess

    if alternative is None:
        return ServerProcess(host, *args).wait_ready()
    command = shlex.split(alternative.replace("{host}", host))
    return ServerProcess(host, command=command, ready=ALTERNATIVE_READY).wait_ready()


def _stat(path: str) -> tuple[str, float]:
    """(comm, utime + stime in seconds) of a /proc stat file (a process's or a thread's)."""
    with open(path) as f:
        head, tail = f.read().rsplit(")", 1)  # comm may contain spaces and parentheses
    fields = tail.split()
    return head.split("(", 1)[1], (int(fields[11]) + int(fields[12])) / CLK_TCK  # 14, 15


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (all its threads), in seconds."""
    return _stat(f"/proc/{pid}/stat")[1]


def thread_cpu_seconds(pid: int) -> dict[str, float]:
    """utime + stime per thread name of a process (threads of one name summed)."""
    out: dict[str, float] = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            name, seconds = _stat(f"/proc/{pid}/task/{tid}/stat")
        except OSError:  # exited meanwhile
            continue
        out[name] = out.get(name, 0.0) + seconds
    return out


def memory_mib(pid: int) -> tuple[float, float]:
    """(resident, anonymous) MiB of pid. The resident set includes the libraries' code pages,
    which every process mapping the same files shares; the anonymous part (heap, stacks, the
    model and data) is the process's own: what each further server adds to a machine."""
    found = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "RssAnon"):
                found[key] = int(value.split()[0]) / 1024
    return found.get("VmRSS", float("nan")), found.get("RssAnon", float("nan"))


def cpu_percent(pid: int, seconds: float) -> float:
    """CPU used by pid over the next `seconds`, as % of one core."""
    c0, t0 = cpu_seconds(pid), time.perf_counter()
    time.sleep(seconds)
    return 100 * (cpu_seconds(pid) - c0) / (time.perf_counter() - t0)


class Load:
    """How busy the rest of the machine was over a window (a caveat for every timing figure).

    `other` is the CPU time of all processes except `exclude`, in % of one core (exact per-task
    times; processes that both start and exit inside the window are missed). `pressure` is the
    share of the window in which some task waited for a CPU (PSI, /proc/pressure/cpu). The
    aggregate /proc/stat counters are not used: on this VM they under-count a 1 kHz loop.
    """

    def __init__(self, exclude: set[int]) -> None:
        self.exclude = exclude | {os.getpid()}
        self.t0, self.cpu0, self.psi0 = time.perf_counter(), self._cpu(), _psi_some_us()

    def _cpu(self) -> dict[int, float]:
        out = {}
        for name in os.listdir("/proc"):
            if name.isdigit() and int(name) not in self.exclude:
                try:
                    out[int(name)] = cpu_seconds(int(name))
                except (OSError, IndexError, ValueError):
                    pass  # exited meanwhile
        return out

    def stop(self) -> tuple[float, float]:
        """(other processes % of a core, CPU pressure % of the window)."""
        cpu1, psi1, wall = self._cpu(), _psi_some_us(), time.perf_counter() - self.t0
        used = sum(c - self.cpu0.get(pid, 0.0) for pid, c in cpu1.items())
        return 100 * used / wall, 100 * (psi1 - self.psi0) / 1e6 / wall


def _psi_some_us() -> float:
    try:
        with open("/proc/pressure/cpu") as f:
            return float(f.readline().rsplit("total=", 1)[1])
    except (OSError, IndexError):
        return float("nan")


def idle_behaviour() -> str:
    """How this machine's CPUs idle, when that changes the figures: a guest whose cpuidle driver
    is haltpoll with its polling at 0 exits to the host every time a vCPU idles, and the thread
    that wakes there next runs its work ~2× slower (docs/benchmarks.md, "What bounds the
    figures"). "" when the machine does not say."""
    try:
        with open("/sys/devices/system/cpu/cpuidle/current_driver") as f:
            driver = f.read().strip()
        with open("/sys/module/haltpoll/parameters/guest_halt_poll_ns") as f:
            poll_ns = int(f.read())
    except (OSError, ValueError):
        return ""
    if driver != "haltpoll":
        return ""
    if poll_ns == 0:
        return "; guest halt polling off (an idle vCPU exits to the host at once)"
    return f"; guest halt polling {poll_ns / 1000:g} µs"


def verdict(ok: bool) -> str:
    return "ok" if ok else "MISS"
