"""The image on the daemon's default bridge with its ports published (`docker run -p`), driven
by pylibfranka from the host through each way in (build_and_run.py --bridge):

  loopback   the published loopback address: Docker's userland proxy relays the TCP connection,
             so the server sees it come from the bridge's gateway, as the UDP answers do
  own        an address of the host's own: iptables NAT, no proxy; the server sees the TCP
             connection come from that address and the UDP answers from the bridge's gateway,
             an address translation it follows (one log line, checked here)
  namespace  the host's address on a link to another network namespace, as a client on another
             machine comes: NAT both ways (the states leave masqueraded as the host's address,
             the answers come back through the same translation)

Nothing UDP is published: the states go from the container to the client, and the answers
come back to the server's socket, by routing (and NAT). The control API is asked through the
host's published addresses too.
"""

from __future__ import annotations

import os
import re
import time
from contextlib import ExitStack

from docker_cli import Docker, StepFailed
from drive import drive_apart
from host_network import namespace_link, own_address

from franka_sim.control import Control

PORTS = (1337, 1338, 1340)  # the robot, the Hand, the control API
MOVED = "UDP commands of the client at"  # the server's line when it follows a translation
CONNECTED = re.compile(r"FCI client (\S+):\d+ connected")  # where it saw the TCP peer


def gateway(docker: Docker) -> str:
    """The default bridge network's gateway (StepFailed when the daemon has no bridge)."""
    done = docker.run("publish", "network", "inspect", "bridge", "--format",
                      "{{range .IPAM.Config}}{{.Gateway}}{{end}}", check=False)
    if done.returncode != 0 or not done.stdout.strip():
        raise StepFailed("publish", "the daemon has no default bridge network")
    return done.stdout.strip()


def run_and_drive(docker: Docker, image: str, name: str, loopback: str, cleanup: ExitStack,
                  run) -> dict:
    """Start `image` as `name` on the bridge (`run`: build_and_run.run) and drive it through
    each way in; what each took and what the server said about it."""
    report: dict = {"gateway": gateway(docker)}
    if os.geteuid() != 0:
        raise StepFailed("network", "an address of the host's own and a namespace need root")
    own = cleanup.enter_context(own_address())
    namespace, link, report["namespace_client"] = cleanup.enter_context(namespace_link())
    addresses = {"loopback": loopback, "own": own, "namespace": link}
    publish = [f"--publish={address}:{port}:{port}/tcp"
               for address in addresses.values() for port in PORTS]
    report["run_s"] = round(run(docker, image, name, *publish), 2)
    for label, address in addresses.items():
        prefix = ("ip", "netns", "exec", namespace) if label == "namespace" else ()
        if label != "namespace":  # (the namespace's own client is pylibfranka alone)
            _control_answers(address, label)
        seen = len(docker.run("drive", "logs", name).stderr.splitlines())
        took = drive_apart(address, f"drive ({label}, {address})", prefix)
        lines = docker.run("drive", "logs", name).stderr.splitlines()[seen:]
        moved = [line for line in lines if MOVED in line]
        peers = [match[1] for line in lines if (match := CONNECTED.search(line))]
        report[label] = {"address": address, "drive_s": round(took, 2),
                         "tcp_peer": peers[0] if peers else None,
                         "answers_moved": moved[0] if moved else None}
    return report


def _control_answers(address: str, label: str, timeout: float = 10.0) -> None:
    """The control API through the published port 1340 says the robot is ready."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            if Control(address, timeout=2.0).health().get("ready"):
                return
            why = "not ready"
        except Exception as exc:  # noqa: BLE001 - whatever the client raised, in one line
            why = f"{type(exc).__name__}: {exc}"
        if time.monotonic() > deadline:
            raise StepFailed(f"control API ({label}, {address})", why)
        time.sleep(0.2)
