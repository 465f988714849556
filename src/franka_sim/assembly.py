"""A world's parts built from a Config: what the server wires to its sockets and what replay
runs without any. Built in one place so that a replayed run starts from the very robots the
recorded one did.

`WorldParts` resolves the scene, places the arms (the --arm poses, else the scene's `arm/NAME`
sites, else the origin), checks that they can stand there, and builds the physics; each arm's
own parts (description, core, Hand, sessions) are an `ArmParts`.
"""

from __future__ import annotations

import numpy as np

from franka_sim.config import ArmSpec, Config
from franka_sim.description.mobile_base import base_urdf_text
from franka_sim.description.urdf import ArmDescription, default_urdf_text, load_arm_description
from franka_sim.physics.mobile_base import BaseBody
from franka_sim.physics.mujoco_backend import ArmBackend
from franka_sim.physics.scene import (ArmPlacement, SceneError, check_world, default_scene_path,
                                      resolve_scene, scene_mounts)
from franka_sim.physics.world import World
from franka_sim.robot.base_cycle import BaseCycle
from franka_sim.robot.core import RobotCore
from franka_sim.robot.cycle import RobotCycle
from franka_sim.robot.gripper import Gripper
from franka_sim.robot.mobile_base import BaseCore
from franka_sim.robot.requests import RequestHandler
from franka_sim.robot.session import Session, gripper_session, robot_session
from franka_sim.robot.world_cycle import WorldCycle


class ArmParts:
    """One arm's description, core and Hand (None: --no-gripper), and its sessions."""

    def __init__(self, config: Config, spec: ArmSpec, description: ArmDescription,
                 urdf_text: str) -> None:
        self.config, self.spec = config, spec
        self.description, self.urdf_text = description, urdf_text
        self.q0 = np.array(config.q0, dtype=float)
        self.core = RobotCore(
            description, self.q0, enforce_comm_constraints=config.enforce_comm_constraints,
            enforce_motion_limits=config.enforce_motion_limits,
            joint_discontinuity_scale=config.joint_discontinuity_scale,
        )
        # The Hand: without it (--no-gripper) nothing listens on 1338 and the hand is rigid.
        self.gripper = Gripper() if config.gripper else None

    def make_cycle(self, physics, hand_state_wanted=lambda: True) -> RobotCycle:
        return RobotCycle(self.core, physics, self.gripper, hand_state_wanted=hand_state_wanted)

    def robot_session(self) -> Session:
        return robot_session(RequestHandler(self.core, self.urdf_text.encode()))

    def gripper_session(self) -> Session:
        return gripper_session(self.gripper)


class WorldParts:
    """The scene, where each arm stands, and each arm's parts (SceneError: they cannot)."""

    def __init__(self, config: Config) -> None:
        self.config = config
        self.urdf_text = (
            config.urdf.read_text() if config.urdf is not None else default_urdf_text()
        )
        self.description = load_arm_description(self.urdf_text)
        self.scene = resolve_scene(config.scene) if config.scene is not None \
            else default_scene_path()
        specs = config.arm_specs()
        self.placements = self._place(specs)
        self._check()
        self.arms = [ArmParts(config, spec, self.description, self.urdf_text) for spec in specs]
        # The mobile base (--mobile-base): a robot of its own after the arms, which ride on it.
        self.base = None if config.mobile_base is None else BaseCore(base_urdf_text().encode())

    def _place(self, specs) -> list[ArmPlacement]:
        """Each arm where its spec says, else where the scene's `arm/NAME` site does, else at
        the origin; a lone arm keeps the arm's own names ("hand", "flange")."""
        for i, spec in enumerate(specs):
            for other in specs[:i]:
                if other.name == spec.name:
                    raise SceneError(f"arm {spec.name}: two arms have that name")
                if other.host == spec.host:
                    raise SceneError(f"arm {spec.name}: {spec.host} serves arm {other.name} "
                                     "already (one address per arm)")
            if spec.host == self.config.mobile_base:
                raise SceneError(f"arm {spec.name}: {spec.host} serves the mobile base "
                                 "(one address per robot)")
        mounts = scene_mounts(self.scene)
        fingers, rides = self.config.gripper, self.config.mobile_base is not None
        return [ArmPlacement(self.description, spec.name if len(specs) > 1 else "",
                             base=spec.base if spec.base is not None else mounts.get(spec.name),
                             fingers=fingers, rides=rides)
                for spec in specs]

    def _check(self) -> None:
        check_world(self.placements, self.scene)
        if len(self.placements) > 1:
            for a, b in World(self.placements, self._q0s(), scene_xml=self.scene).touching_arms():
                raise SceneError(f"arm {a}: placed into arm {b} (their bodies intersect at the "
                                 "starting pose; move their bases apart)")

    def _q0s(self) -> dict:
        q0 = np.array(self.config.q0, dtype=float)
        return {p.name: q0 for p in self.placements}

    def make_physics(self) -> list:
        """The world (in the thread that will own it), as each arm's view of it, by index,
        then the mobile base's body if there is one."""
        world = World(self.placements, self._q0s(), scene_xml=self.scene)
        physics = [ArmBackend(world, p.name) for p in self.placements]
        if self.base is not None:
            physics.append(BaseBody(world.model, world.data))
        return physics

    def make_cycle(self, physics: list, hand_state_wanted) -> RobotCycle | WorldCycle:
        """One arm: its RobotCycle. Several (or a mobile base): a WorldCycle around the
        world's one step. `hand_state_wanted[i]`: whether arm i's Hand client takes
        GripperStates."""
        cycles = [arm.make_cycle(physics[i], hand_state_wanted[i])
                  for i, arm in enumerate(self.arms)]
        if self.base is not None:
            cycles.append(BaseCycle(self.base, physics[len(self.arms)]))
        if len(cycles) == 1:
            return cycles[0]
        return WorldCycle(cycles, physics[0].world.step)
