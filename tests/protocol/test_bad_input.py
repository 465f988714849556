"""Malformed input is rejected one exchange at a time, and the robot keeps serving."""

from __future__ import annotations

import socket
import struct

import pylibfranka
import pytest


def _closed_by_server(s: socket.socket) -> bool:
    s.settimeout(5)
    try:
        while True:
            data = s.recv(4096)
            if not data:
                return True
    except ConnectionResetError:
        return True
    except socket.timeout:
        return False


def _connected(host: str, udp_port: int = 40000) -> socket.socket:
    s = socket.create_connection((host, 1337), timeout=5, source_address=(host, 0))
    s.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, udp_port))
    reply = s.recv(15)
    assert struct.unpack("<IIIBH", reply)[3] == 0
    return s


def _still_serves(host: str) -> None:
    r = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    assert r.read_once().robot_mode == pylibfranka.RobotMode.Idle
    del r


@pytest.mark.parametrize(
    "payload, what",
    [
        (struct.pack("<III", 99, 1, 12), "unknown command id"),
        (struct.pack("<III", 1, 1, 12), "Move whose header size lies (too small)"),
        (struct.pack("<III", 2, 1, 500) + b"\0" * 488, "StopMove with a padded size"),
        (struct.pack("<III", 4, 1, 64 * 1024 * 1024), "absurd size"),
        (struct.pack("<III", 4, 1, 4), "size smaller than the header"),
    ],
)
def test_malformed_frames_close_that_connection_only(sim, payload, what, caplog):
    s = _connected(sim.host)
    s.sendall(payload)
    assert _closed_by_server(s), what
    s.close()
    _still_serves(sim.host)


def test_command_before_connect_closes(sim):
    s = socket.create_connection((sim.host, 1337), timeout=5, source_address=(sim.host, 0))
    s.sendall(struct.pack("<III", 11, 0, 12))  # GetRobotModel first
    assert _closed_by_server(s)
    s.close()
    _still_serves(sim.host)


def test_truncated_message_then_hangup(sim):
    s = _connected(sim.host)
    s.sendall(struct.pack("<III", 4, 1, 68) + b"\0" * 20)  # SetJointImpedance cut short
    s.close()
    _still_serves(sim.host)


def test_udp_garbage_and_foreign_datagrams_are_dropped_with_one_line_each(sim):
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind((sim.host, 0))
    udp.settimeout(2)
    tcp = _connected(sim.host, udp.getsockname()[1])
    try:
        _, server_addr = udp.recvfrom(2048)  # states come from the robot's UDP socket
        udp.sendto(b"garbage", server_addr)  # right sender, wrong size
        foreign = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        foreign.bind((sim.host, 0))
        foreign.sendto(b"\0" * 371, server_addr)  # well-formed, from a stranger
        foreign.close()
        assert sim.wait_for_log("not the connected client")
        assert sim.wait_for_log("dropped UDP datagram from the client")
        udp.recv(2048)  # the stream goes on
    finally:
        tcp.close()
        udp.close()
    _still_serves(sim.host)
