"""The MuJoCo engine's world and robot bodies (physics/engine.py's protocols): physics/world.py's
World, an arm's body (physics/mujoco_backend.py) for each placement, and the mobile base's."""

from __future__ import annotations

import logging
from typing import Mapping

import numpy as np

from franka_sim.physics.engine import Physics
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)
_warnings = 0


def _mujoco_warning(text: str) -> None:
    """MuJoCo's warnings (an unstable step it reset, a full contact buffer) as log lines, not
    bare text on stderr; thinned as any repeated event is."""
    global _warnings
    _warnings += 1
    if worth_logging(_warnings):
        log.warning("MuJoCo: %s (%d so far)", text.strip(), _warnings)


def make_physics(placements, q0s: Mapping[str, np.ndarray], scene, *,
                 mobile_base: bool = False) -> Physics:
    """The world of `placements` (physics/scene.py) in `scene`, each arm's body in it by index,
    then the mobile base's body if the arms ride one."""
    from franka_sim.physics.mobile_base import BaseBody
    from franka_sim.physics.mujoco_backend import ArmBackend
    from franka_sim.physics.world import World as MujocoWorld

    import mujoco

    mujoco.set_mju_user_warning(_mujoco_warning)
    world = MujocoWorld(placements, q0s, scene_xml=scene)
    robots = [ArmBackend(world, placement.name) for placement in placements]
    if mobile_base:
        robots.append(BaseBody(world.model, world.data))
    return Physics(world, tuple(robots))
