"""The mobile base's drive, sans-IO: a body twist in, the planar pose and the swerve modules out.

Each cycle the base follows the commanded body twist (vx, vy, wz) within its speed and
acceleration limits (description/mobile_base.py), integrates it into its planar pose in the
frame where it started, and turns the twist into each module's steering angle and wheel speed
(swerve inverse kinematics: a module at r in the base frame moves at (vx − wz·r_y, vy + wz·r_x)).
A module steers the shorter way: past a quarter turn it reverses its wheel instead. A module
that does not move keeps its angle.
"""

from __future__ import annotations

import math

from franka_sim.description.mobile_base import (FRONT_MODULE, MAX_ACCELERATION, MAX_SPEED,
                                                MAX_YAW_ACCELERATION, MAX_YAW_RATE, REAR_MODULE,
                                                WHEEL_RADIUS)
from franka_sim.protocol.timing import CYCLE_PERIOD as DT

MODULES = (FRONT_MODULE, REAR_MODULE)
STILL = 1e-9  # m/s: a module slower than this keeps its steering angle


def _clamp_norm(x: float, y: float, limit: float) -> tuple[float, float]:
    norm = math.hypot(x, y)
    if norm <= limit:
        return x, y
    return x * limit / norm, y * limit / norm


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


class SwerveDrive:
    """The base's planar state: pose (x, y, yaw), the twist it moves at, and the modules'
    joints q/dq in libfranka's order (front steer, front drive, rear steer, rear drive)."""

    def __init__(self) -> None:
        self.x = self.y = self.yaw = 0.0
        self.vx = self.vy = self.wz = 0.0
        self.q = [0.0, 0.0, 0.0, 0.0]
        self.dq = [0.0, 0.0, 0.0, 0.0]

    @property
    def moving(self) -> bool:
        return self.vx != 0.0 or self.vy != 0.0 or self.wz != 0.0 or any(self.dq)

    def step(self, vx: float, vy: float, wz: float) -> None:
        """One cycle towards the body twist (vx, vy, wz), within the limits."""
        vx, vy = _clamp_norm(vx, vy, MAX_SPEED)
        wz = _clamp(wz, MAX_YAW_RATE)
        dvx, dvy = _clamp_norm(vx - self.vx, vy - self.vy, MAX_ACCELERATION * DT)
        self.vx, self.vy = self.vx + dvx, self.vy + dvy
        self.wz += _clamp(wz - self.wz, MAX_YAW_ACCELERATION * DT)
        if abs(self.vx) < STILL and abs(self.vy) < STILL and abs(self.wz) < STILL:
            self.vx = self.vy = self.wz = 0.0  # a stop is exact, not a 1e-17 creep
        # The pose: the body twist turned into the start frame at the mid-cycle heading.
        heading = self.yaw + 0.5 * self.wz * DT
        c, s = math.cos(heading), math.sin(heading)
        self.x += (c * self.vx - s * self.vy) * DT
        self.y += (s * self.vx + c * self.vy) * DT
        self.yaw += self.wz * DT
        self._modules()

    def _modules(self) -> None:
        q, dq = self.q, self.dq
        for i, (rx, ry) in enumerate(MODULES):
            mx, my = self.vx - self.wz * ry, self.vy + self.wz * rx
            speed = math.hypot(mx, my)
            steer = q[2 * i]
            if speed > STILL:
                wanted = math.atan2(my, mx)
                turn = math.remainder(wanted - steer, 2 * math.pi)
                if abs(turn) > 0.5 * math.pi:  # the shorter way: turn less, drive backwards
                    turn = math.remainder(turn + math.pi, 2 * math.pi)
                    speed = -speed
                dq[2 * i] = turn / DT
                q[2 * i] = steer + turn
            else:
                speed, dq[2 * i] = 0.0, 0.0
            dq[2 * i + 1] = speed / WHEEL_RADIUS
            q[2 * i + 1] += dq[2 * i + 1] * DT

    def pose_matrix(self) -> list[list[float]]:
        """The planar pose as a 4×4 transform (rows)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return [[c, -s, 0.0, self.x], [s, c, 0.0, self.y], [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0]]
