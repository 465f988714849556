"""The physics seam: what an engine provides, so the robot runs on it unchanged.

An engine builds a `World` from the arms' placements, their start poses and the scene
(`make_physics`), and gives each arm its body in it (an `ArmBody`, the protocol of
physics/backend.py's `Backend`: drive, measure, queries, its tool). The cycle thread owns the
`Physics` of a world: the world and every robot's body in it, by robot index (an arm's
`ArmBody`, the mobile base's body). MuJoCo is the engine today (physics/world.py, physics/arm.py,
physics/mujoco_backend.py; its `make_physics`: physics/mujoco_engine.py) by default, Genesis the
second (physics/genesis/, the `genesis` extra); each implements these protocols and its own
`make_physics`, physics/engine_choice.py chooses by the engine's name (ENGINES), and nothing
above physics/ changes. docs/engines.md says how to add one.

Contracts the robot relies on, which an engine must keep (the MuJoCo engine's tests check them):
- one `step()` advances every arm by exactly `timestep` (0.001 s) with the command each arm was
  last given; `finish_step()` does the part of the step no reading needs (a server calls it once
  the states have left) and changes no bit of what the next step gives;
- identity: an arm's command (JointCommand) is a value its arrays are never written into after
  it is handed over: the engine may compare a command with the last by identity to know that
  nothing changed (robot/drive.py hands the same object while it holds); a tool's command is
  compared by equality;
- rest: when a step changes nothing (state and inputs the same), `ArmBody.measure()` hands back
  the very same Measured object as before, and the robot takes that identity as "at rest"
  (robot/arm_cycle.py). A step that cannot tell may return a new object: only speed is lost;
- everything that changes the world from outside (place, push, reset) is called between two
  steps, on the thread that steps, and takes effect from the next step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Protocol, Sequence

import numpy as np

from franka_sim.physics.backend import Backend as ArmBody
from franka_sim.physics.bodies import BodyState


class Bodies(Protocol):
    """The world's bodies by name (physics/bodies.py: names, which are free, lookups)."""

    names: tuple[str, ...]

    def is_free(self, name: str) -> bool: ...

    def find(self, name: str) -> str:
        """The body's own name for `name` (UnknownBody if none)."""

    def free_qpos(self) -> list[tuple[str, int]]:
        """(name, address of its position and quaternion in `positions()`) of each free body."""


class World(Protocol):
    """One physics world: every arm of it, the scene's bodies, one step for all."""

    timestep: float
    bodies: Bodies

    def step(self) -> None:
        """Advance everything by one timestep, each arm with its last command."""

    def finish_step(self) -> None:
        """The rest of the last step (see the module docstring)."""

    def body_state(self, name: str) -> BodyState:
        """A body's pose and velocity now (UnknownBody if there is none of that name)."""

    def place_body(self, name: str, position, quaternion=None) -> None:
        """A free body at `position` (turned to `quaternion`; None: as it is), at rest
        (NotFree for a link or a fixed body; Inside, the world unchanged, where it would be
        inside another body: physics/bodies.py)."""

    def push(self, name: str, force, torque, steps: int) -> None:
        """A wrench on a body (world frame, at its centre of mass) for the next `steps`
        (Immovable for a body no force moves; TooViolent past what a step integrates)."""

    def reset(self, q0: Mapping[str, np.ndarray],
              tool_settings: Mapping[str, object] | None = None) -> None:
        """Everything as at the start, each arm at rest at its pose in `q0`."""

    def reset_arm(self, name: str, q0, tool_setting: object | None = None) -> None:
        """One arm at rest at q0; the rest of the world as it is."""

    def intrusions(self, name: str, q0, tool_setting: object | None = None) -> list:
        """What arm `name` reset to q0 (its tool at its start, or at `tool_setting`) would be
        inside (physics/intrusions.py); no change."""

    def touching_arms(self) -> list[tuple[str, str]]:
        """Pairs of arms whose bodies touch now (placed into each other), by name."""

    def positions(self) -> np.ndarray:
        """Every position of the world now, as one array (a view: copy what you keep), for
        recordings and viewers of this engine."""


@dataclass(frozen=True)
class Physics:
    """What the cycle thread owns: the world and each robot's body in it, by robot index."""

    world: World
    robots: Sequence[object]

    def arm(self, index: int) -> ArmBody:
        return self.robots[index]


__all__ = ["ArmBody", "Bodies", "Physics", "World"]
