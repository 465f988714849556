"""The MuJoCo implementation of the physics Backend: one arm's view of a world.

The world (physics/world.py) steps, the arm (physics/arm.py) drives and reads; `ArmBackend` is
the Backend protocol over them for one arm of a world that may hold several. `MujocoBackend` is
the common case, a world of one arm with the arm's own names ("hand", "flange",
"fr3_joint1", ...) and the scene's objects as "scene/<name>".

With several arms, the world steps once for all of them: each arm's cycle gives its arm its
command (`command`), then the world steps (`World.step`), then each reads (`measure`).
"""

from __future__ import annotations

import os

import mujoco
import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.physics.arm_model import ROTOR_INERTIA_FR3
from franka_sim.physics.backend import WorldArmBody
from franka_sim.physics.scene import ArmPlacement
from franka_sim.physics.tool import ToolMount
from franka_sim.physics.world import World

_UNPREPARED = object()


class ArmBackend(WorldArmBody):
    """One arm of `world` (by name); not thread-safe (the cycle thread serialises access)."""

    def __init__(self, world: World, name: str) -> None:
        super().__init__(world, name)
        self.model: mujoco.MjModel = world.model
        self.data: mujoco.MjData = world.data
        self._scratch = world.scratch  # where the queries leave their kinematics
        self._queries = self.arm.queries

    def flange_pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F and the flange Jacobian at q from one kinematics pass (the desired-state path)."""
        return self._queries.flange_pose_and_jacobian(q)

    # What tests look at: whether the last step's finish is still to do (a server's send order
    # relies on it), and what g(q) is prepared for (assigning anything else has the next step
    # compute it at its start).
    @property
    def _unfinished(self) -> bool:
        return self.world.unfinished

    @property
    def _prepared_for(self) -> object:
        return self.arm.prepared_load if self.world.prepared else _UNPREPARED

    @_prepared_for.setter
    def _prepared_for(self, load: object) -> None:
        if load is not self._prepared_for:
            self.world.forget_gravity()

    # -- run-time changes -------------------------------------------------------------------------
    def reset(self, q0, tool_setting: object | None = None) -> None:
        """At rest at q0: gravity compensation alone holds the arm, so sensors read rest values;
        its tool at its start, or at `tool_setting` (the Hand's opening). In a world of one arm everything
        else is back where it started too; in a world of several, the others and the bodies
        are left as they are (another arm's client may be at work)."""
        if len(self.world.arms) == 1:
            settings = None if tool_setting is None else {self.arm.name: tool_setting}
            self.world.reset({self.arm.name: q0}, settings)
        else:
            self.world.reset_arm(self.arm.name, q0, tool_setting)

    def intrusions(self, q0, tool_setting: object | None = None) -> list:
        """What a `reset` to q0 would put the arm inside (World.intrusions)."""
        return self.world.intrusions(self.arm.name, q0, tool_setting)

    def set_end_effector(self, mass: float, com, inertia) -> None:
        """Replace the rigid body on the flange (see World.set_end_effector)."""
        self.world.set_end_effector(self.arm.name, mass, com, inertia)

    # -- queries (scratch data, state untouched) --------------------------------------------------
    def gravity(self, q) -> np.ndarray:
        return self._queries.gravity(q)

    def coriolis(self, q, dq) -> np.ndarray:
        return self._queries.coriolis(q, dq)

    def mass_matrix(self, q, *, include_armature: bool = False) -> np.ndarray:
        return self._queries.mass_matrix(q, include_armature=include_armature)

    def jacobian_flange(self, q) -> np.ndarray:
        return self._queries.jacobian_flange(q)

    def flange_pose(self, q) -> np.ndarray:
        """O_T_F at q computed by MuJoCo (for cross-checks against the numpy kinematics)."""
        return self._queries.flange_pose(q)


class MujocoBackend(ArmBackend):
    """One arm in a world of its own, at the origin, with the arm's own names."""

    def __init__(self, desc: ArmDescription, q0, *, scene_xml: str | os.PathLike | None = None,
                 armature=ROTOR_INERTIA_FR3, tool: ToolMount | None = None) -> None:
        placement = ArmPlacement(desc, tool=tool, armature=tuple(armature))
        super().__init__(World([placement], {placement.name: q0}, scene_xml=scene_xml),
                         placement.name)
