"""Shared helpers for the benchmarks: spawn/stop `franka-sim serve`, a raw v10 client, /proc stats.

Not a benchmark itself. Everything here uses only the standard library so the figures do not
depend on the package under test (except for spawning its console script).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import socket
import struct
import subprocess
import sys
import sysconfig
import threading
import time
from pathlib import Path

PRIVATE_HOST = "127.0.0.200"
ROBOT_PORT = 1337
STATE_SIZE = 1377
CLK_TCK = os.sysconf("SC_CLK_TCK")
_CMSG_SPACE = socket.CMSG_SPACE(16)  # one struct timespec
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux value; Python lacks the name


def serve_command(host: str) -> list[str]:
    """The `franka-sim` console script of *this* interpreter (skips pyenv's shim), then PATH."""
    script = Path(sysconfig.get_path("scripts")) / "franka-sim"
    exe = str(script) if script.exists() else shutil.which("franka-sim")
    if exe is None:
        sys.exit("franka-sim not found: pip install -e . first")
    return [exe, "serve", "--host", host]


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


class Server:
    """A `franka-sim serve` subprocess (or another `command`); a thread drains its stderr.

    `serving_at` is the perf_counter() instant the "serving on" log line was read.
    """

    def __init__(self, host: str = PRIVATE_HOST, command: list[str] | None = None) -> None:
        self.host = host
        self.spawned_at = time.perf_counter()
        self.proc = subprocess.Popen(
            command or serve_command(host), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE, text=True, bufsize=1,
        )
        self.pid = self.proc.pid
        self.serving_at: float | None = None
        self.log: list[str] = []
        self._serving = threading.Event()
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        for line in self.proc.stderr:
            if self.serving_at is None and "serving on" in line:
                self.serving_at = time.perf_counter()
                self._serving.set()
            if len(self.log) < 200:
                self.log.append(line.rstrip())
        self._serving.set()  # EOF: the process died before serving

    def wait_serving(self, timeout: float = 20.0) -> float:
        """Seconds from spawn to the "serving on" line."""
        if not self._serving.wait(timeout) or self.serving_at is None:
            self.stop()
            sys.exit("server did not start:\n" + "\n".join(self.log[-20:]))
        return self.serving_at - self.spawned_at

    def stop(self, timeout: float = 10.0) -> float:
        """SIGTERM, wait for exit; seconds it took (inf if it had to be killed after `timeout`)."""
        if self.proc.poll() is not None:
            return 0.0
        # A blocking wait: Popen.wait(timeout) polls with growing sleeps and would quantise this.
        watchdog = threading.Timer(timeout, self.proc.kill)
        watchdog.start()
        t0 = time.perf_counter()
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait()
        took = time.perf_counter() - t0
        watchdog.cancel()
        return took if self.proc.returncode != -signal.SIGKILL else float("inf")


class RawClient:
    """The minimal v10 client: TCP Connect handshake, then a UDP socket receiving RobotState."""

    def __init__(self, host: str, timeout: float = 2.0) -> None:
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        # Kernel arrival timestamps: tell server-side jitter from this client's own scheduling.
        self.udp.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        self.udp.bind((host, 0))
        self.udp.settimeout(timeout)
        udp_port = self.udp.getsockname()[1]
        # The server streams to the TCP peer's IP, so TCP must leave from the UDP socket's IP.
        self.tcp = socket.create_connection((host, ROBOT_PORT), timeout, source_address=(host, 0))
        self.tcp.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, udp_port))
        reply = b""
        while len(reply) < 15:
            chunk = self.tcp.recv(15 - len(reply))
            if not chunk:
                raise ConnectionError("server closed the connection during Connect")
            reply += chunk
        status = struct.unpack("<IIIBH", reply)[3]
        if status != 0:
            raise ConnectionError(f"Connect rejected with status {status}")

    def recv_state(self) -> tuple[int, int, int]:
        """(perf_counter_ns right after recv, message_id, kernel arrival ns) of the next state."""
        data, anc, _, _ = self.udp.recvmsg(2048, _CMSG_SPACE)
        t = time.perf_counter_ns()
        if len(data) != STATE_SIZE:
            raise ValueError(f"RobotState datagram of {len(data)} bytes, expected {STATE_SIZE}")
        sec, nsec = struct.unpack("<qq", anc[0][2]) if anc else (0, 0)
        return t, struct.unpack_from("<Q", data)[0], sec * 1_000_000_000 + nsec

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()


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
