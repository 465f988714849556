"""Answers to the robot's TCP commands after the handshake.

Each handler validates its request as the robot does and returns the reply bytes now, or —
for Move, whose final answer comes when the motion ends — registers the command id so the
core can answer it later.
"""

from __future__ import annotations

import logging

from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.enums import (
    BaseStatus,
    Command,
    GetterSetterStatus,
    RobotMode,
)
from franka_sim.robot.core import RobotCore
from franka_sim.robot.settings import (
    CollisionThresholds,
    InvalidArgument,
    Load,
    homogeneous_from_column_major,
)

log = logging.getLogger(__name__)


class RequestHandler:
    """Dispatches decoded requests to the robot core; one per client session."""

    def __init__(self, core: RobotCore, urdf: bytes) -> None:
        self.core = core
        self.urdf = urdf

    def handle(self, command: Command, command_id: int, request) -> list[bytes]:
        if command is Command.GetRobotModel:
            return [msg.build_response(command, command_id, BaseStatus.kSuccess, urdf=self.urdf)]
        if command in _SETTERS:
            return [msg.build_response(command, command_id, self._set(command, request))]
        if command is Command.Move:
            return self.core.request_move(command_id, request)
        if command is Command.StopMove:
            return self.core.request_stop(command_id)
        if command is Command.AutomaticErrorRecovery:
            return self.core.request_recovery(command_id)
        raise AssertionError(f"unhandled command {command!r}")  # the framing knows all 12

    def _set(self, command: Command, request) -> GetterSetterStatus:
        if self.core.robot_mode is RobotMode.kMove:
            # Parameters are latched when a motion starts; the robot refuses changes mid-motion.
            log.info("%s refused: a motion is running", command.name)
            return GetterSetterStatus.kCommandNotPossibleRejected
        try:
            _SETTERS[command](self.core, request)
        except InvalidArgument as exc:
            log.warning("%s rejected: %s", command.name, exc)
            return GetterSetterStatus.kInvalidArgumentRejected
        return GetterSetterStatus.kSuccess


def _set_collision(core: RobotCore, req) -> None:
    core.settings.collision = CollisionThresholds.from_request(req)


def _set_joint_impedance(core: RobotCore, req) -> None:
    core.settings.set_joint_impedance(req.K_theta)


def _set_cartesian_impedance(core: RobotCore, req) -> None:
    core.settings.set_cartesian_impedance(req.K_x)


def _set_guiding(core: RobotCore, req) -> None:
    core.settings.guiding_mode = tuple(bool(b) for b in req.guiding_mode)
    core.settings.guiding_nullspace = bool(req.nullspace)


def _set_ee_to_k(core: RobotCore, req) -> None:
    core.settings.EE_T_K = homogeneous_from_column_major("EE_T_K", req.EE_T_K)


def _set_ne_to_ee(core: RobotCore, req) -> None:
    core.settings.NE_T_EE = homogeneous_from_column_major("NE_T_EE", req.NE_T_EE)


def _set_load(core: RobotCore, req) -> None:
    core.set_load(Load.from_request(req))


_SETTERS = {
    Command.SetCollisionBehavior: _set_collision,
    Command.SetJointImpedance: _set_joint_impedance,
    Command.SetCartesianImpedance: _set_cartesian_impedance,
    Command.SetGuidingMode: _set_guiding,
    Command.SetEEToK: _set_ee_to_k,
    Command.SetNEToEE: _set_ne_to_ee,
    Command.SetLoad: _set_load,
}

