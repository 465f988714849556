"""The host's side of the private daemon's networking, made by the test and taken back after.

- `Bridge`: the Linux bridge the daemon's default bridge network uses (`dockerd --bridge`),
  on a subnet of its own, so that the test never touches a `docker0` of the machine's; with
  iptables on, as Docker is normally run (NAT for published ports, the userland proxy). What
  dockerd adds to iptables and to ip_forward stays after it stops, so the nat and filter
  tables and ip_forward are saved before and put back after. Not made when another docker
  already manages iptables (its DOCKER chain is there): two daemons would fight over it.
- `own_address`: an address of the host's own, on a device of its own (a dummy, or an empty
  bridge where the kernel has no dummy driver), as a client on the host may connect to.
- `namespace_link`: another network namespace joined to the host by a veth pair, as a client
  on another machine would reach the host.

Addresses are private (10.252-254.N.x, N from the process id), device names ≤ 15 bytes.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from contextlib import contextmanager
from pathlib import Path

from docker_cli import StepFailed, last_line

IP_FORWARD = Path("/proc/sys/net/ipv4/ip_forward")


def _n() -> int:
    return os.getpid() % 250


def ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        raise StepFailed("network", f"`ip {' '.join(args)}`: {last_line(done.stderr)}")


class Bridge:
    def __init__(self) -> None:
        n = _n()
        self.name = f"fsimbr{os.getpid() % 100000}"
        self.gateway = f"10.252.{n}.1"
        self.cidr = f"{self.gateway}/24"
        self._saved: dict[str, str] = {}
        self._forward: str | None = None

    @staticmethod
    def why_not() -> str | None:
        """Why the daemon cannot have a bridge here (None: it can)."""
        for tool in ("ip", "iptables", "iptables-save", "iptables-restore"):
            if shutil.which(tool) is None:
                return f"{tool} is not installed (Debian: iproute2, iptables)"
        done = subprocess.run(["iptables", "-t", "nat", "-S"], capture_output=True, text=True,
                              timeout=30)
        if done.returncode != 0:
            return f"iptables does not work here: {last_line(done.stderr)}"
        if "-N DOCKER" in done.stdout.split("\n"):
            return "another docker daemon manages iptables on this machine"
        return None

    def make(self) -> None:
        """Save iptables and ip_forward, then the bridge device with its gateway address."""
        for table in ("nat", "filter"):
            done = subprocess.run(["iptables-save", "-t", table], capture_output=True,
                                  text=True, timeout=30, check=True)
            self._saved[table] = done.stdout
        self._forward = IP_FORWARD.read_text()
        ip("link", "add", self.name, "type", "bridge")
        ip("addr", "add", self.cidr, "dev", self.name)
        ip("link", "set", self.name, "up")

    def remove(self) -> None:
        """After the daemon stopped: the device goes, iptables and ip_forward are put back."""
        subprocess.run(["ip", "link", "del", self.name], capture_output=True, timeout=30)
        for saved in self._saved.values():
            subprocess.run(["iptables-restore"], input=saved, capture_output=True, text=True,
                           timeout=30)
        if self._forward is not None:
            IP_FORWARD.write_text(self._forward)
        self._saved, self._forward = {}, None

    def daemon_flags(self) -> list[str]:
        return [f"--bridge={self.name}", "--iptables=true", "--ip6tables=false"]


@contextmanager
def own_address():
    """An address of the host's own (not loopback), on a device made for it."""
    device, address = f"fsimown{os.getpid() % 100000}", f"10.253.{_n()}.1"
    try:
        ip("link", "add", device, "type", "dummy")
    except StepFailed:  # no dummy driver: an empty bridge holds an address as well
        ip("link", "add", device, "type", "bridge")
    try:
        ip("addr", "add", f"{address}/32", "dev", device)
        ip("link", "set", device, "up")
        yield address
    finally:
        subprocess.run(["ip", "link", "del", device], capture_output=True, timeout=30)


@contextmanager
def namespace_link():
    """(namespace, the host's address on the link to it, the namespace's): a /30 between
    them."""
    tag = os.getpid() % 100000
    ns, ours, theirs = f"fsimns{tag}", f"fsimva{tag}", f"fsimvb{tag}"
    subnet = f"10.254.{_n()}"
    ip("netns", "add", ns)
    try:
        ip("link", "add", ours, "type", "veth", "peer", "name", theirs)
        ip("link", "set", theirs, "netns", ns)
        ip("addr", "add", f"{subnet}.1/30", "dev", ours)
        ip("link", "set", ours, "up")
        ip("netns", "exec", ns, "ip", "addr", "add", f"{subnet}.2/30", "dev", theirs)
        ip("netns", "exec", ns, "ip", "link", "set", theirs, "up")
        ip("netns", "exec", ns, "ip", "link", "set", "lo", "up")
        yield ns, f"{subnet}.1", f"{subnet}.2"
    finally:
        subprocess.run(["ip", "link", "del", ours], capture_output=True, timeout=30)
        subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)
