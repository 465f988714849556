"""Connecting: what a libfranka client sees when it opens and closes the robot connection."""

from __future__ import annotations

import socket
import struct
import subprocess
import sys

import pylibfranka
import pytest

from franka_sim.testing import running_sim


ROBOT_PORT = 1337


def _connect(host: str) -> pylibfranka.Robot:
    return pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)


def test_pylibfranka_connects_and_reads_an_idle_robot(robot):
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert state.control_command_success_rate == 0.0


def test_disconnect_then_reconnect_at_once(sim):
    first = _connect(sim.host)
    t1 = first.read_once().time.to_sec() * 1000
    del first
    second = _connect(sim.host)
    t2 = second.read_once().time.to_sec() * 1000
    assert t2 > t1  # the robot's clock kept counting across clients
    del second


def test_second_simultaneous_client_is_turned_away_and_first_keeps_working(robot, sim):
    with pytest.raises(pylibfranka.NetworkException):
        _connect(sim.host)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def _raw_connect(host: str, version: int, udp_port: int = 40000) -> bytes:
    with socket.create_connection((host, ROBOT_PORT), timeout=2) as s:
        s.sendall(struct.pack("<IIIHH", 0, 0, 16, version, udp_port))
        data = b""
        while len(data) < 15:
            chunk = s.recv(64)
            if not chunk:
                break
            data += chunk
        return data


@pytest.mark.parametrize("version", [4, 11])
def test_wrong_library_version_gets_incompatible_and_our_version(sim, version):
    """A version neither v10 nor one served beside it (v9: tests/clients/test_older_libfranka.py)."""
    reply = _raw_connect(sim.host, version=version)
    command, command_id, size, status, version = struct.unpack("<IIIBH", reply[:15])
    assert (command, command_id, size) == (0, 0, 15)
    assert status == 1  # kIncompatibleLibraryVersion
    assert version == 10
    # ...and the robot is still there for a client that speaks v10.
    r = _connect(sim.host)
    assert r.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_a_panda_refusing_a_version_names_its_own():
    """libfranka 0.8 (protocol 4) at a Panda: the refusal names 5, the libfranka to use with
    this robot, not the newest the simulator serves (--strict-versions or not)."""
    with running_sim("--robot", "fer") as panda:
        reply = _raw_connect(panda.host, version=4)
    assert struct.unpack("<IIIBH", reply[:15]) == (0, 0, 15, 1, 5)


def test_port_taken_is_a_clear_one_line_error_and_nonzero_exit(sim):
    second = subprocess.run(
        [sys.executable, "-m", "franka_sim", "serve", "--host", sim.host],
        capture_output=True, text=True, timeout=60,
    )
    assert second.returncode != 0
    assert "already in use" in second.stderr
    assert second.stderr.strip().count("\n") == 0 or "Traceback" not in second.stderr


def test_a_client_that_reconnects_at_once_is_never_taken_for_a_second_client(sim):
    for _ in range(20):
        s = socket.create_connection((sim.host, ROBOT_PORT), timeout=2)
        s.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, 40000))
        assert struct.unpack("<IIIBH", s.recv(15))[3] == 0
        s.close()
        r = _connect(sim.host)  # right after the close: before the server has read the EOF
        assert r.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del r
    assert not sim.log_matching("refused FCI client")


def _read_exactly(s: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n and (chunk := s.recv(n - len(data))):
        data += chunk
    return data


def test_a_model_library_for_another_machine_is_answered_k_error_and_serving_goes_on(sim):
    """libfranka 0.9 (protocol 5) asks for the library of its own machine; one this machine
    cannot build for is the robot's kError (one log line), and the session and the server go
    on: the same connection's next request is answered."""
    from franka_sim.model_library.build import this_machine

    other = 1 if this_machine()[0] != "kX86" else 0  # kX86, else kX64
    with socket.create_connection((sim.host, ROBOT_PORT), timeout=5) as s:
        s.sendall(struct.pack("<IIIHH", 0, 0, 16, 5, 40000))
        assert struct.unpack("<IIIBH", _read_exactly(s, 15)) == (0, 0, 15, 0, 5)
        s.sendall(struct.pack("<IIIBB", 13, 1, 14, other, 0))  # v5's LoadModelLibrary
        assert struct.unpack("<IIIB", _read_exactly(s, 13)) == (13, 1, 13, 1)  # kError
        s.sendall(struct.pack("<III", 12, 2, 12))  # v5's AutomaticErrorRecovery
        command, command_id, size, status = struct.unpack("<IIIB", _read_exactly(s, 13))
        assert (command, command_id, size) == (12, 2, 13)
    assert sim.log_matching("this machine makes one for")
    r = _connect(sim.host)
    assert r.read_once().robot_mode == pylibfranka.RobotMode.Idle
