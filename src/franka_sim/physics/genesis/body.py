"""The ArmBody (physics/backend.py's Backend protocol) of the arm of a Genesis world."""

from __future__ import annotations

import numpy as np

from franka_sim.description import kinematics
from franka_sim.physics.backend import WorldArmBody
from franka_sim.physics.genesis.world import GenesisWorld
from franka_sim.spatial import jacobian_in_base, pose_in_base


class GenesisArmBody(WorldArmBody):
    """The arm `name` of `world`; not thread-safe (the cycle thread serialises access)."""

    def __init__(self, world: GenesisWorld, name: str) -> None:
        super().__init__(world, name)
        arm = self.arm
        self._dynamics = arm.dynamics
        self._armature = np.asarray(arm.placement.armature, float)
        self._base = arm.placement.base_frame()

    def reset(self, q0, tool_setting: object | None = None) -> None:
        """At rest at q0, its tool at its start or at `tool_setting`; the world as at its
        start."""
        settings = None if tool_setting is None else {self.arm.name: tool_setting}
        self.world.reset({self.arm.name: q0}, settings)

    def intrusions(self, q0, tool_setting: object | None = None) -> list:
        return self.world.intrusions(self.arm.name, q0, tool_setting)

    def set_end_effector(self, mass: float, com, inertia) -> None:
        self.world.set_end_effector(self.arm.name, mass, com, inertia)

    # -- queries: Genesis's solver on the arm's own scene (physics/genesis/dynamics.py) ------------
    def _tool_q(self) -> np.ndarray:
        return self.arm.q[7:]

    def gravity(self, q) -> np.ndarray:
        return self._dynamics.gravity_all(np.asarray(q, float), self._tool_q())[:7].copy()

    def coriolis(self, q, dq) -> np.ndarray:
        q = np.asarray(q, float)
        bias, _ = self._dynamics.bias_and_mass(q, np.asarray(dq, float), self._tool_q())
        return bias - self.gravity(q)

    def mass_matrix(self, q, *, include_armature: bool = False) -> np.ndarray:
        _, M = self._dynamics.bias_and_mass(np.asarray(q, float), None, self._tool_q())
        if not include_armature:
            M[np.diag_indices(7)] -= self._armature
        return M

    def flange_pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F and J_F at q (the desired state's, every cycle of a motion): the description's
        kinematics, which Genesis's equal to rounding (tests/engines), at a fraction of a
        Genesis query's cost; `flange_pose` and `jacobian_flange` ask Genesis."""
        q = np.asarray(q, float)
        return kinematics.flange_pose(self.desc, q), kinematics.tip_jacobian(self.desc, q)

    def _genesis_flange(self, q) -> tuple[np.ndarray, np.ndarray]:
        pose, J = self._dynamics.flange_pose_and_jacobian(np.asarray(q, float), self._tool_q())
        if self._base is not None:
            pose_in_base(pose, self._base)
            J = jacobian_in_base(J, self._base)
        return pose, J

    def jacobian_flange(self, q) -> np.ndarray:
        return self._genesis_flange(q)[1]

    def flange_pose(self, q) -> np.ndarray:
        return self._genesis_flange(q)[0]
