"""A client whose host vanishes (no FIN, no RST) frees the single-client slot within ~10 s.

The client lives in a network namespace of its own, joined to ours by a veth pair; its host
"vanishes" when its end of the link goes down and the client is killed: nothing it sends can
leave, so the server only learns from TCP keepalive that nobody answers. Needs root and
iproute2 (CI runs as root and installs iproute2); skips with the reason otherwise. The
endpoint's real bounds are used: this is the figure docs/robustness.md quotes.
"""

from __future__ import annotations

import os
import shutil
import socket
import struct
import subprocess
import sys
import textwrap
import time

import pytest
from support.embedded import CONNECT, ROBOT, serving

CLIENT = textwrap.dedent("""
    import socket, struct, sys, time
    s = socket.create_connection((sys.argv[1], 1337), timeout=10)
    s.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, 40000))
    assert s.recv(15)[12] == 0
    print("connected", flush=True)
    time.sleep(3600)
""")


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


@pytest.fixture
def vanishing_link():
    """(namespace, its veth end, our address, its address): a /30 between us and a namespace."""
    if os.geteuid() != 0:
        pytest.skip("needs root to make a network namespace")
    if shutil.which("ip") is None:
        pytest.skip("needs iproute2 (ip)")
    tag = f"fs{os.getpid() % 100000}"
    ns, ours, theirs = f"{tag}ns", f"{tag}a", f"{tag}b"
    subnet = f"10.{200 + os.getpid() % 50}.{os.getpid() % 250}"
    try:
        _ip("netns", "add", ns)
    except subprocess.CalledProcessError as exc:
        pytest.skip(f"cannot make a network namespace: {exc.stderr.decode().strip()}")
    try:
        _ip("link", "add", ours, "type", "veth", "peer", "name", theirs)
        _ip("link", "set", theirs, "netns", ns)
        _ip("addr", "add", f"{subnet}.1/30", "dev", ours)
        _ip("link", "set", ours, "up")
        _ip("netns", "exec", ns, "ip", "addr", "add", f"{subnet}.2/30", "dev", theirs)
        _ip("netns", "exec", ns, "ip", "link", "set", theirs, "up")
        yield ns, theirs, f"{subnet}.1", f"{subnet}.2"
    finally:
        subprocess.run(["ip", "link", "del", ours], capture_output=True)
        subprocess.run(["ip", "netns", "del", ns], capture_output=True)


def _newcomer_served(host: str) -> bool:
    """A Connect from our side: answered (the slot is free), or closed (still taken)."""
    try:
        with socket.create_connection((host, ROBOT), timeout=5) as s:
            s.sendall(CONNECT[ROBOT])
            reply = s.recv(15)
            return len(reply) == 15 and struct.unpack("<IIIBH", reply)[3] == 0
    except OSError:
        return False


def test_a_vanished_host_frees_the_slot_within_about_ten_seconds(vanishing_link):
    ns, their_link, our_address, _ = vanishing_link
    with serving(our_address) as sim:
        client = subprocess.Popen(["ip", "netns", "exec", ns, sys.executable, "-c", CLIENT,
                                   our_address], stdout=subprocess.PIPE, text=True)
        try:
            assert client.stdout.readline().strip() == "connected"
            assert not _newcomer_served(our_address)  # one client at a time
            _ip("netns", "exec", ns, "ip", "link", "set", their_link, "down")
            vanished = time.monotonic()
            client.kill()  # its FIN can no longer leave: the host is gone as far as we know
            client.wait(10)
            while sim.fci.active is not None and time.monotonic() - vanished < 60:
                time.sleep(0.2)
            freed = time.monotonic() - vanished
        finally:
            client.kill()
        assert sim.fci.active is None, "the dead peer still holds the slot after 60 s"
        assert freed < 20, f"freed after {freed:.1f} s"  # ~10 s: keepalive 5 s + 5 × 1 s
        assert _newcomer_served(our_address)
