"""The platform floor for control_loop.py: the least a server can do for a control loop.

One thread answers a libfranka client as a robot's protocol requires and does nothing else:
Connect, Move (kMotionStarted, the modes flip on the next state, kSuccess after the state that
ends the motion), every other request answered kSuccess; the states carry only message_id,
the modes and robot_mode (everything else zero), and the commands are not looked at beyond
their message_id and finished flags. No physics, no checks, no event loop.

Its cycles are released like franka-sim's: on absolute 1 ms deadlines (`--clock realtime`, the
commands read at each deadline), or during a motion as soon as the open cycle is answered
(`--clock lockstep`, within a 100 ms window, as franka-sim's; like franka-sim's physics thread
it reads the socket for the answer for up to 300 µs before it sleeps on it, which here makes it
about twice as fast as sleeping at once). So `control_loop.py --reference`
shows what this machine and this client allow: the CPU one cycle costs without any work, and
the fastest lockstep any server could reach with this client. With `--physics` each motion
cycle also runs the stripped torque cycle of benchmarks/_floor.py under the answer's tau_J_d
(stepped before the state is sent, finished after): the floor under a server that simulates at
all, with none of franka-sim's features.

    python benchmarks/reference_responder.py --host 127.0.0.201 [--clock lockstep] [--physics]
"""

from __future__ import annotations

import argparse
import select
import socket
import struct
import sys
import time

from _common import reference_process
from _floor import StrippedCycle
from franka_sim.description.urdf import default_urdf_text
from franka_sim.protocol.codec import COMMAND_DTYPE, StateBuffer, decode_command
from franka_sim.protocol.enums import (Command, ConnectStatus, ControllerMode, MotionGeneratorMode,
                                       MoveStatus, RobotMode)
from franka_sim.protocol.framing import FrameReader, decode_request
from franka_sim.protocol.robot_messages import REQUEST_SIZES, CommandHeader, build_response
from franka_sim.robot.motion import parse_move
from franka_sim.server.cycle_driver import LOCKSTEP_SPIN
from franka_sim.server.pacing import LOCKSTEP_WINDOW

URDF = default_urdf_text().encode()
_MOTION_DONE = COMMAND_DTYPE.fields["motion_generation_finished"][1]
_TORQUE_DONE = COMMAND_DTYPE.fields["torque_command_finished"][1]


class Responder:
    def __init__(self, host: str, lockstep: bool, physics: bool = False) -> None:
        self.lockstep = lockstep
        self.physics = StrippedCycle() if physics else None
        self.tau_J_d = (0.0,) * 7  # the last answer's torque (--physics)
        self.server = socket.create_server((host, 1337))
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind((host, 0))
        self.udp.setblocking(False)
        self.state = StateBuffer()
        self.state.robot_mode[...] = int(RobotMode.kIdle)
        self.idle_modes()
        self.message_id = 0
        self.tcp: socket.socket | None = None
        self.target: tuple[str, int] | None = None
        self.reader = FrameReader(CommandHeader, REQUEST_SIZES)
        self.move: tuple[int, tuple] | None = None  # (Move command_id, the modes to show)
        self.running = False  # the modes have flipped: the client streams commands
        self.answered = True  # the open cycle's command arrived
        self.finished = False  # that command ends the motion
        self.after_state: list[bytes] = []  # replies sent after the next state

    def idle_modes(self) -> None:
        self.state.motion_generator_mode[...] = int(MotionGeneratorMode.kIdle)
        self.state.controller_mode[...] = int(ControllerMode.kJointImpedance)

    def serve(self) -> None:
        print(f"reference responder serving on {self.server.getsockname()[0]}:1337",
              file=sys.stderr, flush=True)
        self.tcp, _ = self.server.accept()
        deadline = time.monotonic()
        while True:
            lockstep = self.lockstep and self.running
            if lockstep and not self.answered:
                self.spin_for_answer()
            if not (lockstep and self.answered):
                timeout = (deadline + LOCKSTEP_WINDOW if lockstep else deadline) - time.monotonic()
                readable = [self.tcp, self.udp] if lockstep else [self.tcp]
                ready, _, _ = select.select(readable, [], [], max(timeout, 0.0))
                if self.tcp in ready:
                    self.on_tcp()
                self.read_commands()
            if lockstep and not self.answered and time.monotonic() < deadline + LOCKSTEP_WINDOW:
                continue
            if not lockstep and time.monotonic() < deadline:
                continue
            self.release()
            deadline = time.monotonic() if lockstep else deadline + 1e-3

    def on_tcp(self) -> None:
        data = self.tcp.recv(65536)
        if not data:
            sys.exit(0)
        for frame in self.reader.feed(data):
            command = Command(frame.command)
            if command is Command.Connect:
                request = decode_request(frame)
                self.target = (self.tcp.getpeername()[0], request.udp_port)
                self.tcp.sendall(build_response(command, frame.command_id,
                                                ConnectStatus.kSuccess, version=10))
            elif command is Command.Move:
                spec = parse_move(decode_request(frame))
                self.move = (frame.command_id, spec.state_modes)
                self.after_state.append(
                    build_response(command, frame.command_id, MoveStatus.kMotionStarted))
            elif command is Command.GetRobotModel:  # pylibfranka asks for it on connecting
                self.tcp.sendall(build_response(command, frame.command_id, 0, urdf=URDF))
            else:
                self.after_state.append(build_response(command, frame.command_id, 0))

    def spin_for_answer(self) -> None:
        """Lockstep: read the socket without sleeping for up to LOCKSTEP_SPIN, as franka-sim."""
        spin_until = time.monotonic() + LOCKSTEP_SPIN
        while not self.answered and time.monotonic() < spin_until:
            self.read_commands()

    def read_commands(self) -> None:
        while True:
            try:
                data = self.udp.recv(4096)
            except BlockingIOError:
                return
            if struct.unpack_from("<Q", data)[0] == self.message_id:
                self.answered = True
                if self.physics is not None:
                    self.tau_J_d = decode_command(data)["tau_J_d"]
                self.finished = bool(data[_MOTION_DONE] or data[_TORQUE_DONE])

    def release(self) -> None:
        """The next state (and the replies waiting for it)."""
        s, replies = self.state, []
        if self.move is not None and not self.running:
            self.running = True
            mg, ctrl = self.move[1]
            s.motion_generator_mode[...] = int(mg)
            s.controller_mode[...] = int(ctrl)
            s.robot_mode[...] = int(RobotMode.kMove)
        elif self.running and self.finished:
            self.running = self.finished = False
            self.idle_modes()
            s.robot_mode[...] = int(RobotMode.kIdle)
            replies.append(build_response(Command.Move, self.move[0], MoveStatus.kSuccess))
            self.move = None
        self.message_id += 1
        s.message_id[...] = self.message_id
        self.answered = False
        physics = self.physics if self.running else None
        if physics is not None:
            physics.step(self.tau_J_d)
        if self.target is not None:
            self.udp.sendto(s.pack() if physics is None else physics.write(s, self.message_id),
                            self.target)
        if physics is not None:
            physics.finish()
        replies, self.after_state = self.after_state + replies, []
        for reply in replies:
            self.tcp.sendall(reply)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--host", default="127.0.0.201")
    ap.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime")
    ap.add_argument("--physics", action="store_true",
                    help="run the stripped torque cycle in each motion cycle")
    args = ap.parse_args()
    reference_process()
    Responder(args.host, args.clock == "lockstep", args.physics).serve()


if __name__ == "__main__":
    main()
