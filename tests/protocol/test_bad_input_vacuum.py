"""Malformed input on the vacuum gripper's port (1339) is rejected one exchange at a time, as
on the Hand's: a frame that cannot be parsed closes that connection, a wrong version is
refused with the version we speak, bad arguments answer kFail; the pump keeps serving."""

from __future__ import annotations

import socket
import struct

import pytest

from franka_sim.protocol.vacuum_gripper_messages import (VacuumGripperCommandResponse,
                                                         VacuumGripperConnectResponse,
                                                         build_vacuum_gripper_request)
from franka_sim.testing import running_sim

PORT = 1339


@pytest.fixture(scope="module")
def sim():
    with running_sim("--clock", "lockstep", "--tool", "vacuum") as sim:
        yield sim


def _open(host: str) -> socket.socket:
    return socket.create_connection((host, PORT), timeout=5, source_address=(host, 0))


def _connect(s: socket.socket, version: int = 1):
    s.sendall(build_vacuum_gripper_request(0, 1, version=version, udp_port=40003))
    return VacuumGripperConnectResponse.parse(s.recv(14))


def _closed_by_server(s: socket.socket) -> bool:
    s.settimeout(5)
    try:
        while True:
            if not s.recv(4096):
                return True
    except ConnectionResetError:
        return True
    except socket.timeout:
        return False


def _still_serves(host: str) -> None:
    with _open(host) as s:
        assert _connect(s).status == "kSuccess"
        s.sendall(build_vacuum_gripper_request(3, 2))  # Stop
        assert VacuumGripperCommandResponse.parse(s.recv(12)).status == "kSuccess"


@pytest.mark.parametrize("payload, what", [
    (struct.pack("<HII", 9, 1, 10), "unknown command id"),
    (struct.pack("<HII", 1, 1, 12), "Vacuum whose header size lies (too small)"),
    (struct.pack("<HII", 2, 1, 1 << 20), "absurd size"),
    (struct.pack("<HII", 3, 1, 4), "size smaller than the header"),
])
def test_malformed_frames_close_that_connection_only(sim, payload, what):
    s = _open(sim.host)
    assert _connect(s).status == "kSuccess"
    s.sendall(payload)
    assert _closed_by_server(s), what
    s.close()
    assert sim.log_matching("malformed vacuum_gripper message")
    _still_serves(sim.host)


def test_a_request_before_connect_closes(sim):
    s = _open(sim.host)
    s.sendall(build_vacuum_gripper_request(3, 1))
    assert _closed_by_server(s)
    s.close()
    assert sim.log_matching("vacuum_gripper Stop sent before Connect")
    _still_serves(sim.host)


def test_another_version_is_refused_with_ours(sim):
    s = _open(sim.host)
    reply = _connect(s, version=3)
    assert reply.status == "kIncompatibleLibraryVersion" and reply.version == 1
    assert _closed_by_server(s)
    s.close()
    _still_serves(sim.host)


@pytest.mark.parametrize("command, fields", [
    (1, {"vacuum": 0, "profile": 0, "timeout": 100}),
    (1, {"vacuum": 80, "profile": 9, "timeout": 100}),
    (1, {"vacuum": 80, "profile": 0, "timeout": -1}),
    (2, {"timeout": -1000}),
])
def test_bad_arguments_answer_kfail_and_the_connection_stays(sim, command, fields):
    with _open(sim.host) as s:
        assert _connect(s).status == "kSuccess"
        s.sendall(build_vacuum_gripper_request(command, 5, **fields))
        reply = VacuumGripperCommandResponse.parse(s.recv(12))
        assert reply.status == "kFail" and reply.header.command_id == 5
        s.sendall(build_vacuum_gripper_request(3, 6))
        assert VacuumGripperCommandResponse.parse(s.recv(12)).status == "kSuccess"
