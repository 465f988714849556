"""Drive the robot core and real physics cycle by cycle, without sockets, threads or clocks.

It runs the server's own cycle (`ArmCycle`) in a loop, so robot behaviour can be specified
in microseconds and deterministically.
"""

from __future__ import annotations

import struct

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.protocol.enums import Command, MoveStatus
from franka_sim.protocol.framing import decode_request, Frame
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.arm_cycle import ArmCycle

_DESCRIPTION = load_arm_description(default_urdf_text())


def move_request(controller=0, generator=0, *, use_async=False, maximum_velocity=(0.0,) * 7,
                 deviation=(10.0, 3.12, 2 * np.pi)):
    data = msg.build_request(
        Command.Move, 5, controller_mode=controller, motion_generator_mode=generator,
        maximum_path_deviation=dict(zip(("translation", "rotation", "elbow"), deviation)),
        maximum_goal_pose_deviation=dict(zip(("translation", "rotation", "elbow"), deviation)),
        use_async_motion_generator=use_async, maximum_velocity=list(maximum_velocity),
    )
    return decode_request(Frame(int(Command.Move), 5, data))


def reply_status(reply: bytes) -> tuple[int, int, int]:
    """(command, command_id, status) of a robot TCP reply."""
    command, command_id, _size, status = struct.unpack_from("<IIIB", reply)
    return command, command_id, status


class Harness:
    def __init__(self, q0=READY_POSE, **core_kwargs) -> None:
        self.core = ArmCore(_DESCRIPTION, np.array(q0), **core_kwargs)
        self.robot_cycle = ArmCycle(self.core, MujocoBackend(_DESCRIPTION, np.array(q0)))
        self.state = None
        self.replies: list[bytes] = []
        self.cycle()

    @property
    def backend(self) -> MujocoBackend:
        return self.robot_cycle.physics

    @backend.setter
    def backend(self, backend: MujocoBackend) -> None:  # another scene, the Hand's fingers
        self.robot_cycle.physics = backend

    def cycle(self, n: int = 1):
        for _ in range(n):
            released = self.robot_cycle.release()
            self.state = decode_state(released.state)
            self.replies += self.robot_cycle.complete(released).robot
        return self.state

    def move(self, *args, **kwargs) -> int:
        reply = self.core.request_move(5, move_request(*args, **kwargs))
        return reply_status(reply[0])[2]

    def send(self, message_id=None, **fields) -> bool:
        """A RobotCommand answering the last state (or the given id); True if on time."""
        mid = int(self.state["message_id"]) if message_id is None else message_id
        return self.robot_cycle.receive(decode_command(encode_command(message_id=mid, **fields)))

    def statuses(self) -> list[tuple[int, int, int]]:
        out = [reply_status(r) for r in self.replies]
        self.replies.clear()
        return out


def running_velocity_motion(**kwargs) -> Harness:
    """A joint-velocity motion (joint impedance) started, its first state out."""
    h = Harness(**kwargs)
    assert h.move(0, 1) == MoveStatus.kMotionStarted
    h.cycle()
    return h
