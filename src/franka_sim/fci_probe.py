"""Is an FCI there? A client's first steps of protocol v10, as libfranka takes them: TCP Connect
with version 10 and a UDP port, then one RobotState on that port. Works against a robot as
against the simulator (for `franka-sim check --fci`)."""

from __future__ import annotations

import socket

from franka_sim.blocking_io import recv_exact
from franka_sim.protocol.enums import Command, ConnectStatus
from franka_sim.protocol.robot_messages import ConnectResponse, build_request
from franka_sim.protocol.robot_state import ROBOT_STATE_SIZE

ROBOT_PORT = 1337
PROTOCOL_VERSION = 10
_CONNECT_RESPONSE_SIZE = ConnectResponse.sizeof()


class ProbeFailed(Exception):
    """Why no state arrived, in one line."""


def probe_fci(host: str, timeout: float = 2.0, port: int = ROBOT_PORT) -> int:
    """Connect, wait for one RobotState and disconnect; its message_id. Raises ProbeFailed."""
    where = f"{host}:{port}"
    # Any local address, as libfranka: the robot streams to the TCP peer's address, whichever
    # interface that is (loopback for a simulator, the robot's network for a robot).
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
        udp.bind(("", 0))
        udp.settimeout(timeout)
        try:
            tcp = socket.create_connection((host, port), timeout=timeout)
        except ConnectionRefusedError:
            raise ProbeFailed(f"{where}: connection refused (no FCI there)") from None
        except TimeoutError:
            raise ProbeFailed(f"{where}: no answer within {timeout:g} s") from None
        except OSError as exc:
            raise ProbeFailed(f"{where}: {exc.strerror or exc}") from None
        with tcp:
            try:
                tcp.sendall(build_request(Command.Connect, 1, version=PROTOCOL_VERSION,
                                          udp_port=udp.getsockname()[1]))
                response = ConnectResponse.parse(_recv_exact(tcp, _CONNECT_RESPONSE_SIZE, where))
            except TimeoutError:
                raise ProbeFailed(f"{where}: no Connect response within {timeout:g} s") from None
            except OSError as exc:
                raise ProbeFailed(f"{where}: {exc.strerror or exc} during Connect") from None
            if response.status.intvalue != ConnectStatus.kSuccess:
                raise ProbeFailed(f"{where}: Connect refused ({response.status}; the server "
                                  f"speaks version {response.version}, this client "
                                  f"{PROTOCOL_VERSION})")
            try:
                data = udp.recv(2048)
            except TimeoutError:
                raise ProbeFailed(f"{where}: connected, but no robot state within {timeout:g} s "
                                  "(a firewall on UDP?)") from None
    if len(data) != ROBOT_STATE_SIZE:
        raise ProbeFailed(f"{where}: a datagram of {len(data)} bytes, not a v{PROTOCOL_VERSION} "
                          f"robot state ({ROBOT_STATE_SIZE} bytes)")
    return int.from_bytes(data[:8], "little")


def _recv_exact(sock: socket.socket, n: int, where: str) -> bytes:
    try:
        return recv_exact(sock, n)
    except ConnectionError:
        raise ProbeFailed(f"{where}: the connection was closed during Connect "
                          "(another client connected?)") from None
