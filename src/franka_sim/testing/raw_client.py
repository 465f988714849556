"""A minimal v10 client over raw sockets: the Connect handshake on TCP, states and commands on
UDP. For what libfranka cannot express (bursts of late datagrams, invalid frames, NaNs) and for
measuring the state stream as the kernel delivers it."""

from __future__ import annotations

import socket
import struct
import time

from franka_sim.blocking_io import recv_exact
from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.codec import decode_state, encode_command
from franka_sim.protocol.enums import Command
from franka_sim.protocol.robot_state import ROBOT_STATE_SIZE

ROBOT_PORT = 1337
_CMSG_SPACE = socket.CMSG_SPACE(16)  # one struct timespec
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux value; Python lacks the name


class RawClient:
    """Connected on construction; with `first_state` it also waits for the first state, which
    gives `state` and `server` (where commands go). `timeout` bounds each read of a state; the
    first state is waited for as long as a loaded machine may take to send it
    (`FIRST_STATE_TIMEOUT`: a server still starting its clock)."""

    FIRST_STATE_TIMEOUT = 10.0  # s

    def __init__(self, host: str, timeout: float = 2.0, first_state: bool = True,
                 receive_buffer: int | None = None) -> None:
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if receive_buffer:
            self.udp.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
        # Kernel arrival times (recv_timed): server-side jitter apart from this client's own.
        self.udp.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        self.udp.bind((host, 0))
        self.udp.settimeout(timeout)
        # The server streams to the TCP peer's IP, so TCP must leave from the UDP socket's IP.
        self.tcp = socket.create_connection((host, ROBOT_PORT), timeout=5,
                                            source_address=(host, 0))
        self.tcp.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, self.udp.getsockname()[1]))
        status = struct.unpack("<IIIBH", self._recv_exact(15))[3]
        if status != 0:
            raise ConnectionError(f"Connect rejected with status {status}")
        self.state = None
        self.server: tuple[str, int] | None = None
        self._next_id = 1
        if first_state:
            self.udp.settimeout(max(timeout, self.FIRST_STATE_TIMEOUT))
            data, self.server = self.udp.recvfrom(2048)
            self.udp.settimeout(timeout)
            self.state = decode_state(data)

    def _recv_exact(self, n: int) -> bytes:
        return recv_exact(self.tcp, n)

    def reply(self) -> tuple[int, int, int]:
        """(command, command_id, status) of the next TCP reply."""
        header = self._recv_exact(12)
        command, command_id, size = struct.unpack("<III", header)
        body = self._recv_exact(size - 12)
        return command, command_id, body[0]

    def settle(self, tolerance: float = 1e-4, cycles: int = 3000) -> None:
        """Read states until the arm is at rest (a previous motion may still be braking)."""
        for _ in range(cycles):
            if max(abs(float(v)) for v in self.recv()["dq"]) < tolerance:
                return

    def move(self, controller: int, generator: int) -> int:
        """Send Move; return its first status (1 = kMotionStarted), then wait for the mode flip."""
        self.settle()
        self._next_id += 1
        self.tcp.sendall(msg.build_request(
            Command.Move, self._next_id, controller_mode=controller,
            motion_generator_mode=generator,
            maximum_path_deviation=dict(translation=10.0, rotation=3.12, elbow=6.283),
            maximum_goal_pose_deviation=dict(translation=10.0, rotation=3.12, elbow=6.283),
            use_async_motion_generator=False, maximum_velocity=[0.0] * 7))
        status = self.reply()[2]
        if status == 1:
            while int(self.state["robot_mode"]) != 2:
                self.recv()
        return status

    def recv(self):
        """The next state datagram (blocking), decoded."""
        self.state = decode_state(self.udp.recv(2048))
        return self.state

    def recv_timed(self) -> tuple[int, int, int]:
        """(perf_counter_ns right after the read, message_id, kernel arrival ns) of the next
        state, not decoded: cheap enough to measure a 1 kHz stream."""
        data, anc, _, _ = self.udp.recvmsg(2048, _CMSG_SPACE)
        t = time.perf_counter_ns()
        if len(data) != ROBOT_STATE_SIZE:
            raise ValueError(f"RobotState datagram of {len(data)} bytes, "
                             f"expected {ROBOT_STATE_SIZE}")
        sec, nsec = struct.unpack("<qq", anc[0][2]) if anc else (0, 0)
        return t, struct.unpack_from("<Q", data)[0], sec * 1_000_000_000 + nsec

    def send(self, message_id: int | None = None, **fields) -> None:
        mid = int(self.state["message_id"]) if message_id is None else message_id
        self.udp.sendto(encode_command(message_id=mid, **fields), self.server)

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()
