"""What one simulated robot is: the CLI parses flags/env into this, FrankaSim consumes it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from franka_sim.physics.engine_choice import ENGINES

# The pose libfranka's examples move to before they start ("ready"): a comfortable,
# non-singular configuration well inside every joint range.
READY_POSE = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4)




# How the Desk boots (docs/desk.md): "ready" as the simulator always served, "locked" as after
# power-on.
DESK_BOOTS = ("ready", "locked")


@dataclass(frozen=True)
class ArmSpec:
    """One arm of the world: its name, the address it is served on, and where its base stands.

    `base` is (x, y, z, yaw) in the world frame (m, rad); None: where the scene's `arm/NAME`
    site puts it, else the world origin.
    """

    name: str
    host: str
    base: tuple[float, float, float, float] | None = None
    robot: str | None = None  # its kind (ROBOTS); None: Config.robot's
    tool: str | None = None  # the tool on its flange (franka_sim/tools/); None: Config.tool


# The arms franka-sim simulates: the Franka Research 3 and the Franka Emika Panda (FER), each
# with its packaged description (urdf/NAME.urdf) and limits (robot/checks/figures.py).
class RobotKind(str, Enum):
    fr3 = "fr3"
    fer = "fer"


ROBOTS = tuple(kind.value for kind in RobotKind)
# m from the world's origin: far beyond any scene. An arm's base, or a body placed through the
# control API, stands within it.
WORLD_REACH = 100.0


class ClockMode(str, Enum):
    realtime = "realtime"
    lockstep = "lockstep"


# The physics engines, as the CLI's choices: physics/engine_choice.py's ENGINES (docs/engines.md).
PhysicsEngine = Enum("PhysicsEngine", [(name, name) for name in ENGINES], type=str)


class ToolName(str, Enum):
    """The tools an arm can carry (franka_sim/tools/ has one row for each but `none`)."""

    hand = "hand"
    vacuum = "vacuum"
    none = "none"


@dataclass
class Config:
    host: str = "127.0.0.1"
    robot_port: int = 1337  # libfranka pins it; other values only serve raw-socket clients
    urdf: Path | None = None  # None: the packaged description of each arm's kind
    robot: str = "fr3"  # every arm's kind (ROBOTS) but those whose ArmSpec names their own
    strict_versions: bool = False  # a client must speak the protocols its robot's kind does
    clock: ClockMode = ClockMode.realtime
    physics: str = ENGINES[0]  # the engine, one of ENGINES (docs/engines.md)
    enforce_comm_constraints: bool = False  # abort after 20 lost cycles, as the robot does
    enforce_motion_limits: bool = False  # abort on a limit violation, as the robot does
    joint_discontinuity_scale: float = 1.0  # scales the joint envelope the IK output is held to
    q0: tuple[float, ...] = field(default=READY_POSE)
    tool: str = "hand"  # the tool on every arm's flange (franka_sim/tools/); "none": none
    tool_port: int | None = None  # its service's port; None: its own (the Hand's 1338)
    scene: Path | str | None = None  # a packaged scene's name or an MJCF file; None: the default
    control_port: int = 1340  # the control API (HTTP) on the robot's address; 0: not served
    control_token: str | None = None  # bearer token the control API requires; None: none
    record: Path | None = None  # write everything the run exchanged to this MCAP file
    inject: str | None = None  # network faults on every robot's UDP path (faults/spec.py)
    seed: int = 0  # the faults' seed: the same seed hits the same cycles
    # The Desk (docs/desk.md): its HTTPS port on every arm's address (0: not served), how it
    # boots ("ready": as the simulator always served; "locked": as after power-on), its users
    # (NAME:PASSWORD; none: the documented default) and its certificate (None: one made and
    # kept per user).
    desk_port: int = 0
    desk_boot: str = "ready"
    desk_users: tuple[str, ...] = ()
    desk_cert: Path | None = None
    desk_key: Path | None = None
    # The web view (docs/viewing.md): the world in 3D and each arm's live plots, on the first
    # arm's address; 0: not served.
    web_port: int = 0
    # An installed franka_description whose visual meshes draw the arms (docs/viewing.md);
    # None: our own shapes. Only what is drawn changes.
    meshes: Path | None = None
    # The arms of the world, each on its own address; empty: one arm on host, named after its
    # kind ("fr3", "fer").
    arms: tuple[ArmSpec, ...] = ()
    # The mobile base every arm stands on, served on this address as a robot of its own;
    # None: the arms stand on the world.
    mobile_base: str | None = None

    def arm_specs(self) -> tuple[ArmSpec, ...]:
        return self.arms or (ArmSpec(self.robot, self.host),)

    def robot_of(self, spec: ArmSpec) -> str:
        """The kind of the arm `spec` describes."""
        return spec.robot or self.robot

    def tool_of(self, spec: ArmSpec) -> str:
        """The tool on the flange of the arm `spec` describes."""
        return spec.tool or self.tool
