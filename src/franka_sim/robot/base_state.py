"""The mobile base's RobotState: the arm's message, filled with what a base has.

The mapping follows Franka's ROS 2 driver for its mobile base (the only published user of
it): q/dq[0..3] are the swerve modules' joints (front steer, front drive, rear steer, rear
drive), O_T_EE is the planar pose in the frame where the base started, O_dP_EE_c echoes the
commanded body twist (libfranka anchors the next command on it, as on an arm) and O_dP_EE_d is
the twist the base moves at. The desired and commanded q and poses show the measured ones
(the base follows its twist exactly). Every field an arm alone has stays zero, but the
transforms an arm reports as identities (F_T_EE, NE_T_EE, EE_T_K, F_T_NE) and gravity.
"""

from __future__ import annotations

import numpy as np

from franka_sim.protocol.codec import StateBuffer
from franka_sim.protocol.enums import ControllerMode, MotionGeneratorMode
from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.robot.swerve import SwerveDrive
from franka_sim.spatial import column_major

IDENTITY = column_major(np.eye(4))
GRAVITY = (0.0, 0.0, -9.81)


class BaseStatePublisher:
    def __init__(self) -> None:
        self.buffer = s = StateBuffer()
        for name in ("F_T_EE", "NE_T_EE", "EE_T_K", "F_T_NE"):
            getattr(s, name)[:] = IDENTITY
        s.O_ddP_O[:] = GRAVITY
        self._poses = [s.matrix(name, (4, 4)) for name in ("O_T_EE", "O_T_EE_d", "O_T_EE_c")]
        self._twist_c = (0.0,) * 6  # the commanded twist the buffer holds
        self._modes: tuple | None = None
        self._flags_version = -1
        self.pack(0, SwerveDrive(), None, 1, 0.0, None)  # the start, before any cycle

    def pack(self, message_id: int, drive: SwerveDrive, twist_c, robot_mode: int,
             success_rate: float, modes, status=None) -> bytes:
        """The state of cycle `message_id`. `twist_c`: the client's commanded twist (None:
        no motion); `modes`: (motion generator, controller) of the running motion (None:
        idle); `status`: RobotStatus, whose error bits are rewritten when they changed."""
        s = self.buffer
        s.message_id[...] = message_id
        s.q[:4] = s.q_d[:4] = drive.q
        s.dq[:4] = s.dq_d[:4] = drive.dq
        pose = drive.pose_matrix()
        for view in self._poses:
            view[...] = pose
        d = s.O_dP_EE_d
        d[0], d[1], d[5] = drive.vx, drive.vy, drive.wz
        twist_c = (0.0,) * 6 if twist_c is None else tuple(twist_c)
        previous, self._twist_c = self._twist_c, twist_c
        s.O_dP_EE_c[:] = twist_c
        s.O_ddP_EE_c[:] = [(a - b) / DT for a, b in zip(twist_c, previous)]
        mg, ctrl = modes or (MotionGeneratorMode.kIdle, ControllerMode.kJointImpedance)
        if self._modes != (mg, ctrl, robot_mode):
            self._modes = (mg, ctrl, robot_mode)
            s.motion_generator_mode[...] = int(mg)
            s.controller_mode[...] = int(ctrl)
            s.robot_mode[...] = int(robot_mode)
        if status is not None and status.flags_version != self._flags_version:
            self._flags_version = status.flags_version
            s.errors[:] = status.errors
            s.reflex_reason[:] = status.reflex_reason
        s.control_command_success_rate[...] = success_rate
        return s.pack()

    def restamp(self, message_id: int) -> bytes:
        """The last state again under another message_id."""
        s = self.buffer
        s.message_id[...] = message_id
        return s.pack()
