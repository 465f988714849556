"""A docker daemon of the test's own: started by pid, stopped by pid, its state in one folder.

No systemd here, and a CI machine may run nothing else of docker's: the test starts `dockerd`
itself, on a socket, data root and exec root in a folder of its own, and deletes that folder
after stopping it. Its default bridge network is a bridge of the test's own with iptables on
and the userland proxy (Docker's defaults; host_network.Bridge, taken back after), so that a
container's ports can be published; where that cannot be (no iptables, or another docker
managing it) the daemon has no bridge and `no_bridge` says why (containers then use the host's
network only). overlay2 is tried first, vfs (slower, but works on any filesystem) when the
kernel refuses overlay2. It runs under the normal scheduling policy whatever its caller's
(docker_cli.NORMAL_POLICY): a daemon inheriting SCHED_FIFO 99 from a test process that made a
pylibfranka.Robot livelocks its untar helpers.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

from docker_cli import NORMAL_POLICY, Docker, StepFailed, last_line
from host_network import Bridge

STORAGE_DRIVERS = ("overlay2", "vfs")
# (without --ip-forward=false dockerd turns the machine's forwarding on, and leaves it on)
_NO_BRIDGE = ["--iptables=false", "--ip6tables=false", "--bridge=none", "--ip-forward=false"]


class PrivateDaemon:
    def __init__(self, work: Path) -> None:
        self.work = work  # short: containerd's sockets live under it (unix paths ≤ 107 bytes)
        self.url = f"unix://{work}/docker.sock"
        self.log = work / "dockerd.log"
        self.proc: subprocess.Popen | None = None
        self.driver: str | None = None
        self.bridge: Bridge | None = None  # the default bridge network's, once started
        self.no_bridge: str | None = None  # why the daemon has none

    def start(self, timeout: float = 60.0) -> Docker:
        if shutil.which("dockerd") is None:
            raise StepFailed("daemon", "dockerd is not installed (Debian: docker.io)")
        if os.geteuid() != 0:
            raise StepFailed("daemon", "a private dockerd needs root")
        config = self.work / "daemon.json"
        config.write_text(json.dumps({}))  # not the machine's /etc/docker/daemon.json
        why = "?"
        self.no_bridge = Bridge.why_not()
        tries = [(driver, False) for driver in STORAGE_DRIVERS]
        if self.no_bridge is None:  # with a bridge first, by each driver
            tries = [(driver, True) for driver in STORAGE_DRIVERS] + tries
        for driver, bridged in tries:
            network = self._bridge_flags() if bridged else _NO_BRIDGE
            if network is None:
                continue
            docker = self._try(driver, config, timeout, network)
            if isinstance(docker, Docker):
                self.driver = driver
                if not bridged and self.no_bridge is None:
                    self.no_bridge = "dockerd did not start with one"
                return docker
            why = docker
            if bridged:
                self._remove_bridge()
                self.no_bridge = f"dockerd did not start with one: {docker}"
        raise StepFailed("daemon", f"dockerd did not start: {why}")

    def _bridge_flags(self) -> list[str] | None:
        """The daemon's flags for a bridge of its own (None: it cannot be made, `no_bridge`)."""
        self.bridge = Bridge()
        try:
            self.bridge.make()
        except (StepFailed, OSError, subprocess.SubprocessError) as exc:
            self._remove_bridge()
            self.no_bridge = f"its bridge could not be made: {exc}"
            return None
        return self.bridge.daemon_flags()

    def _remove_bridge(self) -> None:
        bridge, self.bridge = self.bridge, None
        if bridge is not None:
            bridge.remove()

    def _try(self, driver: str, config: Path, timeout: float, network: list[str]) -> Docker | str:
        command = [*NORMAL_POLICY, "dockerd", "--config-file", str(config), "--host", self.url,
                   "--data-root", str(self.work / "data"), "--exec-root", str(self.work / "exec"),
                   "--pidfile", str(self.work / "dockerd.pid"), "--storage-driver", driver,
                   *network]
        with open(self.log, "w") as log:
            self.proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=log,
                                         stderr=subprocess.STDOUT, start_new_session=True)
        docker = Docker(self.url, self.work)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                self.proc = None
                return f"{driver}: {last_line(self.log.read_text(errors='replace'))}"
            if (self.work / "docker.sock").exists() and docker.reachable() is None:
                return docker
            time.sleep(0.2)
        self.stop()
        return f"{driver}: no answer on {self.url} after {timeout:.0f} s"

    def stop(self) -> None:
        """SIGTERM (it stops its containerd and containers), SIGKILL after 20 s; then the
        mounts it may have left and its folder go."""
        proc, self.proc = self.proc, None
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        for mount in _mounts_under(self.work):
            subprocess.run(["umount", "--lazy", mount], capture_output=True)
        self._remove_bridge()
        shutil.rmtree(self.work, ignore_errors=True)


def _mounts_under(folder: Path) -> list[str]:
    """Mount points under `folder`, deepest first."""
    prefix = str(folder) + "/"
    try:
        lines = Path("/proc/self/mountinfo").read_text().splitlines()
    except OSError:
        return []
    points = [line.split()[4] for line in lines if len(line.split()) > 4]
    return sorted((p for p in points if p.startswith(prefix)), key=len, reverse=True)
