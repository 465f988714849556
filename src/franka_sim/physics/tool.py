"""The physics seam of an end-effector tool: what a tool on an arm's flange is in the world.

A tool (the Franka Hand's fingers: physics/fingers.py) is built into the arm's model on the
hand body (`ToolMount.build`), and once the world exists each arm holds the tool's runtime part
(`ToolMount.attach` → `ToolAttachment`), whose hooks the arm calls in the order of the world's
step. Its command comes from the tool's device (robot/tool.py) through the arm's command, and
its reading after each step goes back to the device in the arm's Measured (`tool`). The arm
knows nothing else of it; the tool's kind (franka_sim/tools/) ties the pieces together.

Identity contract: `command` is a value object the device replaces, never mutates, and equal
commands mean the same drive: the world's rest detection compares it with the last step's.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np


class ToolAttachment(Protocol):
    """A tool in the world's data; the arm calls these in the order of the world's step."""

    command: object  # the command it follows now (see the identity contract above)

    def drive(self, command: object | None) -> None:
        """Its forces for this step into the data (`command` replaces the last; None keeps it);
        g(q) is prepared at this q."""

    def settle(self, command: object | None, band: float) -> bool:
        """A standing command's setpoint reached within `band`: put it exactly there, at rest,
        as the arm's idle hold does. True if a position changed."""

    def after_integration(self) -> None:
        """After mj_step2, before the kinematics move on (e.g. keep the end effector's
        composite exact for the tool's new positions)."""

    def reading(self) -> object:
        """What the tool's sensors read after the step (its device's input)."""

    def place(self, setting: object | None) -> None:
        """At its start (or `setting`, e.g. an opening), at rest, in freshly reset data."""

    def placed(self, setting: object | None) -> dict[int, float]:
        """Where `place(setting)` puts its joints: qpos address → value (nothing changes)."""

    def hold(self) -> None:
        """Its share of the idle drive at rest (its gravity load)."""

    def body_placed(self, body: int) -> None:
        """Body `body` was put elsewhere from outside (the control API): a hold on it goes."""

    def set_composite(self, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
        """The flange's rigid body (tool and all) becomes the given one."""


class ToolMount(Protocol):
    """How a tool is built into an arm's model and attached to the world's data."""

    def build(self, spec: mujoco.MjSpec, hand_body: mujoco.MjsBody, prefix: str,
              bits: tuple[int, int]) -> None:
        """Its bodies, joints and the flange body's own inertial on the hand body, and any
        constraint of its own in `spec` (`bits`: the arm's extra contype/conaffinity, OR'ed
        into the tool's geoms)."""

    def attach(self, model: mujoco.MjModel, data: mujoco.MjData, gravity: np.ndarray,
               prefix: str, hand_body: int) -> ToolAttachment:
        """Its runtime part in the world (`gravity`: the world's g(q), all dofs)."""
