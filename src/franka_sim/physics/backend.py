"""What the robot core and the physics exchange once per 1 ms cycle.

The core decides *what the joint drives do* (JointCommand); the backend integrates one step
and reports *what the robot's sensors read* (Measured). Keeping both as plain arrays lets the
core be tested against a fake backend and lets the physics be swapped without touching it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass(frozen=True, eq=False)  # numpy fields: identity, not value, equality
class Payload:
    """A load the robot's model carries on the flange (SetLoad): not a body in the physics.

    The robot compensates its gravity and subtracts its gravity and inertia from the external
    torque estimate; whether anything is really carried is up to the world (a grasped object).
    """

    mass: float  # kg
    F_x_C: np.ndarray  # (3,) m, centre of mass in the flange frame
    inertia: np.ndarray  # (3,3) kg·m², about the centre of mass, in the flange frame's axes


NO_GAINS = np.zeros(7)  # a torque command's q_d, dq_d, K and D (shared, never written)
NO_GAINS.flags.writeable = False


@dataclass(frozen=True, eq=False)  # numpy fields: identity, not value, equality
class JointCommand:
    """What the joint drives are asked to do during one 1 ms step.

    The drive torque is tau_ff + K·(q_d − q) + D·(dq_d − dq) + g(q): the robot always adds its
    own gravity compensation, and in torque mode K = D = 0 so tau_ff is the user torque. g(q)
    is the robot's model: the arm, the end effector and the declared `load` (None: no load).
    With `ddq_d` (a motion generator's reference) the drives also add the torque that gives the
    arm that acceleration, M(q)·ddq_d + c(q, dq): the impedance then only corrects, and the arm
    ends a motion on its q_d instead of lagging it by the inertia over the stiffness.
    """

    tau_ff: np.ndarray  # (7,) Nm
    q_d: np.ndarray  # (7,) rad, impedance set-point
    dq_d: np.ndarray  # (7,) rad/s
    K: np.ndarray  # (7,) Nm/rad
    D: np.ndarray  # (7,) Nm·s/rad
    load: Payload | None = None
    hold: bool = False  # the idle hold: standing still at q_d is the goal (see Rest in the backend)
    ddq_d: np.ndarray | None = None  # (7,) rad/s², the reference's acceleration (feed-forward)

    @classmethod
    def torque(cls, tau) -> "JointCommand":
        """Pure torque control: the user's torque on top of gravity compensation (K and D are
        NO_GAINS itself: the drive skips the impedance terms)."""
        return cls(np.asarray(tau, float), NO_GAINS, NO_GAINS, NO_GAINS, NO_GAINS)

    @classmethod
    def impedance(cls, q_d, K, D, dq_d=None, tau_ff=None, *, hold=False,
                  ddq_d=None) -> "JointCommand":
        """Joint impedance about q_d (e.g. idle holding), optionally with a feed-forward torque
        and the reference's acceleration."""
        zero = np.zeros(7)
        return cls(zero if tau_ff is None else np.asarray(tau_ff, float), np.asarray(q_d, float),
                   zero if dq_d is None else np.asarray(dq_d, float),
                   np.asarray(K, float), np.asarray(D, float), hold=hold,
                   ddq_d=None if ddq_d is None else np.asarray(ddq_d, float))


@dataclass(eq=False)
class Measured:
    """The robot's sensor readings after a step; arrays are fresh per step (safe to keep)."""

    q: np.ndarray  # (7,) link-side joint angle
    dq: np.ndarray  # (7,)
    ddq: np.ndarray  # (7,) acceleration over the last step
    tau_J: np.ndarray  # (7,) link-side joint torque (≈ g(q) at rest, libfranka's sign)
    dtau_J: np.ndarray  # (7,) backward difference over 1 ms
    theta: np.ndarray  # (7,) motor angle (elastic joint: q + tau_J / stiffness)
    dtheta: np.ndarray  # (7,)
    O_T_F: np.ndarray  # (4,4) base → flange (link8)
    accelerometer_top: np.ndarray  # (6,3) specific force in each sensor frame, m/s²
    accelerometer_bottom: np.ndarray  # (6,3)
    tool: object = None  # what the tool on the flange reads (physics/tool.py); None: no tool
    # External joint torque over the last step in the robot's sign: Jᵀ·(the wrench the robot
    # exerts on its environment), i.e. −Jᵀ·(what the environment does to the arm). The
    # declared load's model (gravity and inertia) is already subtracted. None: not measured.
    tau_ext: np.ndarray | None = None  # (7,) Nm
    J_F: np.ndarray | None = None  # (6,7) flange Jacobian at q, base frame, rows [linear; angular]


class Backend(Protocol):
    """A physics engine as the robot core sees it. Synchronous; one thread owns it."""

    timestep: float  # seconds per step(); the robot's clock requires 0.001

    def step(self, cmd: JointCommand, tool: object | None = None) -> Measured:
        """Advance exactly one timestep with the given drive command.

        `tool` replaces the tool's command from this step on; None keeps the last one.
        """

    def finish_step(self) -> None:
        """Do now the part of the last step that no reading depends on (else the next step
        does it first): a server calls it once the state has left, off the client's path."""

    def measure(self) -> Measured:
        """The readings of the last step (or reset), without stepping."""

    def reset(self, q0) -> None:
        """Put the arm at rest at q0 (dq = 0), clearing the torque history."""

    def intrusions(self, q0, tool_setting: object | None = None) -> list:
        """What `reset(q0)` (its tool at its start, or at `tool_setting`) would put the arm
        inside (physics/intrusions.py Intrusion), deepest first; nothing changes."""

    def gravity(self, q) -> np.ndarray:
        """(7,) torque that holds the arm (incl. end effector) still at q."""

    def mass_matrix(self, q, *, include_armature: bool = False) -> np.ndarray:
        """(7,7) joint-space inertia; the rigid-body part unless include_armature."""

    def coriolis(self, q, dq) -> np.ndarray:
        """(7,) C(q, dq)·dq."""

    def jacobian_flange(self, q) -> np.ndarray:
        """(6,7) flange Jacobian in the base frame, rows [linear; angular]."""

    def flange_pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F and jacobian_flange at q in one kinematics pass (desired-state fields)."""

    def set_end_effector(self, mass: float, com, inertia) -> None:
        """Replace what hangs on the flange (hand + load): mass, CoM in F, inertia about CoM."""


class WorldArmBody:
    """An arm's body in a world of several (each engine's ArmBody builds on it): what it is
    given each step goes to its arm (`world.arms[name]`: `command`, `last`), and the world
    steps for all of them."""

    def __init__(self, world, name: str) -> None:
        self.world = world
        self.arm = arm = world.arms[name]
        self.desc = arm.desc
        self.timestep = world.timestep
        self.command = arm.command  # (cmd, tool): what the arm does in the world's next step

    def step(self, cmd: JointCommand, tool: object | None = None) -> Measured:
        """Command this arm and step the world (the world's other arms keep their commands)."""
        self.arm.command(cmd, tool)
        self.world.step()
        return self.arm.last

    def finish_step(self) -> None:
        self.world.finish_step()

    def measure(self) -> Measured:
        return self.arm.last
