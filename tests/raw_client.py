"""A minimal hand-written FCI client over raw sockets, for byte-level and timing-pattern tests
that libfranka cannot express (bursts of late datagrams, invalid frames, NaNs)."""

from __future__ import annotations

import socket
import struct

from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.codec import decode_state, encode_command
from franka_sim.protocol.enums import Command


class RawClient:
    def __init__(self, host: str) -> None:
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind((host, 0))
        self.udp.settimeout(2)
        self.tcp = socket.create_connection((host, 1337), timeout=5, source_address=(host, 0))
        self.tcp.sendall(struct.pack("<IIIHH", 0, 0, 16, 10, self.udp.getsockname()[1]))
        assert struct.unpack("<IIIBH", self._recv_exact(15))[3] == 0
        data, self.server = self.udp.recvfrom(2048)
        self.state = decode_state(data)
        self._next_id = 1

    def _recv_exact(self, n: int) -> bytes:
        out = b""
        while len(out) < n:
            chunk = self.tcp.recv(n - len(out))
            assert chunk, "server closed the connection"
            out += chunk
        return out

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
        """The next state datagram (blocking)."""
        self.state = decode_state(self.udp.recv(2048))
        return self.state

    def send(self, message_id: int | None = None, **fields) -> None:
        mid = int(self.state["message_id"]) if message_id is None else message_id
        self.udp.sendto(encode_command(message_id=mid, **fields), self.server)

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()
