"""The arm's Set* requests: each validates its request as the robot does and changes the
setting it names (robot/settings.py); a refused one changes nothing."""

from __future__ import annotations

import logging
from franka_sim.protocol.enums import Command, GetterSetterStatus
from franka_sim.robot.settings import (
    CollisionThresholds,
    InvalidArgument,
    Load,
    homogeneous_from_column_major,
)

log = logging.getLogger(__name__)


def set_parameter(core, command: Command, request) -> GetterSetterStatus:
    """A Set* request outside a motion (robot/fci.py refuses them during one), on the arm's core
    (robot/arm_core.py: its `settings` and `set_load`)."""
    try:
        _SETTERS[command](core, request)
    except InvalidArgument as exc:
        log.warning("%s rejected: %s", command.name, exc)
        return GetterSetterStatus.kInvalidArgumentRejected
    return GetterSetterStatus.kSuccess


def _set_collision(core, req) -> None:
    core.settings.collision = CollisionThresholds.from_request(req)


def _set_joint_impedance(core, req) -> None:
    core.settings.set_joint_impedance(req.K_theta)


def _set_cartesian_impedance(core, req) -> None:
    core.settings.set_cartesian_impedance(req.K_x)


def _set_guiding(core, req) -> None:
    core.settings.guiding_mode = tuple(bool(b) for b in req.guiding_mode)
    core.settings.guiding_nullspace = bool(req.nullspace)


def _set_ee_to_k(core, req) -> None:
    core.settings.EE_T_K = homogeneous_from_column_major("EE_T_K", req.EE_T_K)


def _set_ne_to_ee(core, req) -> None:
    core.settings.NE_T_EE = homogeneous_from_column_major("NE_T_EE", req.NE_T_EE)


def _set_load(core, req) -> None:
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

