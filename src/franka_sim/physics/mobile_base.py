"""The mobile base's body in the world: a mocap body the arms on it ride on.

The base is moved kinematically: its core (robot/base_core.py) integrates the commanded
twist into a planar pose, and `BaseBody.command` puts the body there before the world's step.
The arms' roots are children of it, so they go where it goes, and each arm reads its flange in
its own root's frame as it is now (physics/readings.py), so an arm's state does not show the
base's motion. MuJoCo gives a mocap body's children no inertial effect of its motion: the arms
ride a perfectly smooth base. The chassis and the column under the mount meet the arms' links
(a link swung into the column is stopped there), but neither the floor nor scene objects.
"""

from __future__ import annotations

import math

import mujoco

from franka_sim.description.mobile_base import (CHASSIS_CLEARANCE, CHASSIS_HALF_SIZE,
                                                COLUMN_HALF_SIZE, FRONT_MODULE, REAR_MODULE,
                                                WHEEL_RADIUS)
from franka_sim.physics.arm_model import COLLISION_BODIES

BASE_BODY = "mobile_base"
# The arms' links and Hand meet the base (their own bits); the environment's bit 0 does not.
_BASE_CONAFFINITY = sum(1 << (i + 1) for i in range(len(COLLISION_BODIES)))


def add_mobile_base(spec: mujoco.MjSpec, mount_height: float) -> mujoco.MjsBody:
    """The base's mocap body at the world origin (where the base starts): chassis, wheels,
    and a column up to `mount_height`, on which the arms stand. Returns it, the arms' parent."""
    body = spec.worldbody.add_body(name=BASE_BODY, mocap=True)
    hx, hy, hz = CHASSIS_HALF_SIZE
    chassis_top = CHASSIS_CLEARANCE + 2 * hz
    solid = dict(contype=0, conaffinity=_BASE_CONAFFINITY, rgba=[0.25, 0.25, 0.28, 1.0])
    body.add_geom(name=f"{BASE_BODY}/chassis", type=mujoco.mjtGeom.mjGEOM_BOX,
                  pos=[0.0, 0.0, CHASSIS_CLEARANCE + hz], size=[hx, hy, hz], **solid)
    column = max(mount_height - chassis_top, 0.0) / 2
    if column > 0.0:
        cx, cy = COLUMN_HALF_SIZE
        body.add_geom(name=f"{BASE_BODY}/column", type=mujoco.mjtGeom.mjGEOM_BOX,
                      pos=[0.0, 0.0, chassis_top + column], size=[cx, cy, column], **solid)
    for k, (x, y) in enumerate((FRONT_MODULE, REAR_MODULE)):
        body.add_geom(name=f"{BASE_BODY}/wheel{k}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      pos=[x, y, WHEEL_RADIUS], quat=[math.sqrt(0.5), math.sqrt(0.5), 0, 0],
                      size=[WHEEL_RADIUS, 0.03, 0.0], contype=0, conaffinity=0,
                      rgba=[0.1, 0.1, 0.1, 1.0])
    return body


class BaseBody:
    """Where the base's body is: `command(x, y, yaw)` puts it there (from the next step on)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        mocap = int(model.body_mocapid[model.body(BASE_BODY).id])
        self._pos, self._quat = data.mocap_pos[mocap], data.mocap_quat[mocap]

    def command(self, x: float, y: float, yaw: float) -> None:
        pos, quat = self._pos, self._quat
        pos[0], pos[1] = x, y
        quat[0], quat[3] = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
