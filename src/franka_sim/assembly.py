"""A world's parts built from a Config: what the server wires to its sockets and what replay
runs without any. Built in one place so that a replayed run starts from the very robots the
recorded one did.

`WorldParts` resolves the scene, places the arms (the --arm poses, else the scene's `arm/NAME`
sites, else the origin), checks that they can stand there, and builds the physics and the
world's cycle; each robot's own parts (its core, tools and sessions) are an `ArmParts` or the
mobile base's `BaseParts`, in the world's order: the arms, then the base.
"""

from __future__ import annotations

import numpy as np

from franka_sim.config import ArmSpec, Config
from franka_sim.description.mobile_base import base_urdf_text
from franka_sim.description.urdf import ArmDescription, default_urdf_text, load_arm_description
from franka_sim.log_names import name_work
from franka_sim.physics.engine import Physics
from franka_sim.physics.engine_choice import make_physics
from franka_sim.physics.scene import (ArmPlacement, SceneError, check_world, default_scene_path,
                                      resolve_scene, scene_mounts)
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.arm_cycle import ArmCycle
from franka_sim.robot.base_core import BaseCore
from franka_sim.robot.base_cycle import BaseCycle
from franka_sim.robot.events import NO_ROBOT_EVENTS, NO_WORLD_EVENTS, RobotEvents, WorldEvents
from franka_sim.robot.session import PAIRINGS, Session, robot_session, tool_session
from franka_sim.robot.world_cycle import WorldCycle
from franka_sim.tools import tool_kind


class ArmParts:
    """One arm's description, core and tool (franka_sim/tools/; None: `--tool none`), and its
    sessions."""

    kind = "arm"

    def __init__(self, config: Config, spec: ArmSpec, description: ArmDescription,
                 urdf_text: str, events: RobotEvents = NO_ROBOT_EVENTS) -> None:
        self.config, self.spec = config, spec
        self.name, self.host, self.label = spec.name, spec.host, f"arm {spec.name}"
        self.description, self.urdf_text = description, urdf_text
        self.robot = config.robot_of(spec)  # its kind: fr3 or fer
        self.q0 = np.array(config.q0, dtype=float)
        if np.any(self.q0 < description.lower) or np.any(self.q0 > description.upper):
            raise SceneError(f"arm {spec.name}: its start pose q0 {self.q0.tolist()} is outside "
                             f"its joint limits [{description.lower.tolist()}, "
                             f"{description.upper.tolist()}]")
        self.core = ArmCore(
            description, self.q0, urdf=urdf_text.encode(), enforce_comm_constraints=config.enforce_comm_constraints,
            enforce_motion_limits=config.enforce_motion_limits,
            joint_discontinuity_scale=config.joint_discontinuity_scale, events=events,
        )
        self.core.status.held = config.desk_boot != "ready"  # (its Desk frees it: arm_desk.py)
        # Its tool: without one (--tool none) nothing listens on the tool's port and the Hand's
        # body is rigid.
        self.tool_kind = tool_kind(config.tool_of(spec))
        self.tool = None if self.tool_kind is None else self.tool_kind.make_device()
        self._model_library = None  # made for the first client that asks (model_library())

    def make_part(self, physics, tool_state_wanted) -> ArmCycle:
        """Its part of the world cycle, on its body in the world; `tool_state_wanted()`: its
        tool's client takes its state datagrams."""
        return ArmCycle(self.core, physics, self.tool, tool_state_wanted=tool_state_wanted)

    def robot_session(self) -> Session:
        return robot_session(self.core, self.model_library, PAIRINGS[self.robot],
                             strict=self.config.strict_versions)

    def model_library(self, request) -> bytes | None:
        """The model library a LoadModelLibrary asks for (libfranka before 0.18 only, so
        model_library/ and the compiler plumbing it imports load on the first such request)."""
        if self._model_library is None:
            from franka_sim.model_library import ModelLibrary

            self._model_library = ModelLibrary(self.description)
        return self._model_library.for_client(request)

    def tool_session(self) -> Session:
        return tool_session(self.tool_kind.service, self.tool)


class BaseParts:
    """The mobile base (--mobile-base ADDRESS): a robot of its own after the arms, which ride on
    it. Its core and its session; no tools."""

    kind = "base"
    name, label = "base", "mobile base"
    tool = tool_kind = None

    def __init__(self, host: str, events: RobotEvents = NO_ROBOT_EVENTS, *,
                 enforce_comm_constraints: bool = False) -> None:
        self.host = host
        self.core = BaseCore(base_urdf_text().encode(), events=events,
                             enforce_comm_constraints=enforce_comm_constraints)

    def make_part(self, physics, tool_state_wanted) -> BaseCycle:
        return BaseCycle(self.core, physics)

    def robot_session(self) -> Session:
        return robot_session(self.core)


# What a robot's part of the world cycle does for it (its log lines are about it).
PART_WORK = ("receive", "drive", "publish", "repeat", "skip", "complete")


class WorldParts:
    """The scene, where each arm stands, and each robot's parts (SceneError: they cannot).

    `events`: who hears what the world and each robot emit (robot/events.py; a recording's
    taps), with one RobotEvents per robot (`events.robots`); None: nobody."""

    def __init__(self, config: Config, events: WorldEvents | None = None) -> None:
        self.config = config
        self.events = events if events is not None else NO_WORLD_EVENTS
        specs = config.arm_specs()
        robot_events = (events.robots if events is not None else
                        [NO_ROBOT_EVENTS] * (len(specs) + (config.mobile_base is not None)))
        # Each arm's (URDF text, description): --urdf's for all, else its kind's packaged one.
        self._descriptions: dict[str, tuple[str, ArmDescription]] = {}
        described = [self._described(config.robot_of(spec)) for spec in specs]
        # The first arm's: what a recording names (each arm's kind is recorded beside it).
        self.urdf_text, self.description = described[0]
        self.scene = resolve_scene(config.scene) if config.scene is not None \
            else default_scene_path()
        self.placements = self._place(specs, [d for _, d in described])
        self._names = tuple(spec.name for spec in specs)  # (the arms', as the server says them)
        # (An arm inside another or a body: SceneError when the world is built, in the cycle
        # thread: engine_choice.make_physics.)
        check_world(self.placements, self.scene)
        self.arms = [ArmParts(config, spec, described[i][1], described[i][0], robot_events[i])
                     for i, spec in enumerate(specs)]
        self.base = None if config.mobile_base is None else BaseParts(
            config.mobile_base, robot_events[len(specs)],
            enforce_comm_constraints=config.enforce_comm_constraints)
        # Every robot of the world, in the world cycle's order: the arms, then the mobile base.
        self.robots = [*self.arms, *([self.base] if self.base is not None else [])]

    def _described(self, robot: str) -> tuple[str, ArmDescription]:
        if robot not in self._descriptions:
            config = self.config
            text = config.urdf.read_text() if config.urdf is not None \
                else default_urdf_text(robot)
            self._descriptions[robot] = (text, load_arm_description(text))
        return self._descriptions[robot]

    def _place(self, specs, descriptions) -> list[ArmPlacement]:
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
            if self.config.mobile_base is not None and spec.name == BaseParts.name:
                raise SceneError(f"arm {spec.name}: the mobile base's name (its log lines, "
                                 "its recording's channels): call the arm otherwise")
        mounts = scene_mounts(self.scene)
        # Arms the scene has sites for, yet none of those names: at the origin (said at start).
        self.unplaced = [] if not mounts else [
            spec.name for spec in specs if spec.base is None and spec.name not in mounts]
        self.sites = sorted(mounts)
        rides = self.config.mobile_base is not None
        kinds = [tool_kind(self.config.tool_of(spec)) for spec in specs]
        looks = self._looks(specs)
        return [ArmPlacement(description, spec.name if len(specs) > 1 else "",
                             base=spec.base if spec.base is not None else mounts.get(spec.name),
                             tool=None if kind is None else kind.mount, rides=rides,
                             look=looks.get(self.config.robot_of(spec)))
                for spec, description, kind in zip(specs, descriptions, kinds)]

    def _looks(self, specs) -> dict:
        """--meshes: each arm kind's visual meshes, read once (MeshError: unusable)."""
        if self.config.meshes is None:
            return {}
        from franka_sim.physics.arm_meshes import MeshError, load_look

        kinds = {self.config.robot_of(spec) for spec in specs}
        try:
            return {kind: load_look(self.config.meshes, kind) for kind in kinds}
        except MeshError as exc:
            raise SceneError(f"--meshes: {exc}") from None

    def _q0s(self) -> dict:
        q0 = np.array(self.config.q0, dtype=float)
        return {p.name: q0 for p in self.placements}

    def make_physics(self) -> Physics:
        """The world (in the thread that will own it) and each robot's body in it, by index
        (physics/engine.py)."""
        return make_physics(self.placements, self._q0s(), self.scene,
                            mobile_base=self.base is not None, engine=self.config.physics,
                            names=self._names)

    def make_cycle(self, physics: Physics, tool_state_wanted) -> WorldCycle:
        """The world's cycle: every robot's part around the world's one step.
        `tool_state_wanted[i]`: whether robot i's tool client takes its state datagrams."""
        parts = [robot.make_part(physics.robots[i], tool_state_wanted[i])
                 for i, robot in enumerate(self.robots)]
        if len(parts) > 1:  # each robot's log lines name it (log_names.py)
            for robot, part in zip(self.robots, parts):
                name_work(part, robot.name, PART_WORK)
                name_work(part.core, robot.name, ("release_cycle",))  # (a held start's)
        return WorldCycle(parts, physics.world.step, self.events)
