"""The Franka Hand's two fingers: geometry, drive, and the palm that keeps the hand exact.

Mechanics (docs/figures.md, "The Franka Hand"). Two prismatic joints on the hand, 0.0584 m along
the hand axis, each opening one finger along the hand's y axis (the NE frame's y, the flange's
turned −45° about z).
Finger 2 is finger 1 turned half a turn about the hand axis, so both share one local geometry and
"+y opens". The datasheet stroke is 0–0.04 m per finger; our mechanical stop sits at 0.0405 m, so
homing (which opens to the stops) measures a max_width of 0.081 m, inside the 0.080–0.082 m real
hands report. At joint position 0 the pads' inner faces meet: width = x1 + x2 exactly.

Coupling. The real Hand drives both fingers with one motor through one mechanism, so they move
as mirror images about the hand's axis: here a stiff, damped coupling between the two joint
positions (finger 2 is finger 1 turned half a turn, so equal positions are mirrored fingers)
stands for that mechanism. A finger that meets an off-centre object first pushes it towards the
axis until the other finger meets it too: a grasp ends centred between the pads, as on the
robot. The coupling is part of the drive's forces, not a solver constraint: with the fingers
mirrored it is exactly zero, so a Hand at rest stays bit-exact at rest.

Drive. One force F = clip(K·(x_d − x̄) + D·(v_d − v̄), −F_lim, F_lim) on the fingers' mean
position x̄ (half the width) goes to each finger joint, plus each finger's own gravity load (so
resting fingers are exactly at rest, like the arm), where F_lim is the command's force (at most
MAX_FINGER_FORCE). Fingers blocked by an object saturate at F_lim, so a grasp squeezes with the
commanded force. Gains and the drive's reflected
inertia along the stroke are our choice (not published): stiff enough to track 0.1 m/s of width
within a fraction of a millimetre, critically damped, and well inside the explicit 1 kHz
stability bound.

Exact hand. The robot reports one rigid end effector (m_ee, F_x_Cee, I_ee); libfranka's Model uses
it. With moving fingers the composite would change with the opening, so the palm's inertial is
recomputed from the finger positions whenever they move: palm = reported composite − fingers. The
hand's total mass, CoM and inertia are then the reported figures at every opening, to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from franka_sim.description import hand
from franka_sim.physics.arm_model import (ARM_CONTACT_PRIORITY, ARM_CONTACT_SOLIMP,
                                          ARM_CONTACT_SOLREF, TOOL_BIT, quat, set_inertial)

FINGER_JOINTS = ("finger_joint1", "finger_joint2")
FINGER_BODIES = ("finger1", "finger2")
FINGER_ORIGIN_Z = 0.0584  # m along the hand axis from the flange
FINGER_STROKE = 0.0405  # m per finger: the mechanical stop (joint range [0, FINGER_STROKE])
OPEN_WIDTH = 0.08  # m: the datasheet opening; the fingers start here

# The finger: a knuckle box under the hand, then the pad (the rubber tip, where an object is
# gripped). The pad is franka_description's tip collision box (docs/figures.md, "The Franka
# Hand"): 18.5 mm tall about the TCP (0.1034 m), so the tips end 9.5 mm beyond it, 0.1129 m from
# the flange. The knuckle is ours: set back from the pad's face, it reaches down to the pad.
FINGER_MASS = 0.03  # kg (the CAD fingers weigh ~0.029 kg: docs/figures.md, "The Franka Hand")
FINGER_COM = np.array([0.0, 0.012, 0.028])  # in the finger frame
FINGER_INERTIA = np.diag([9.8e-6, 1.0e-5, 2.0e-6])  # about the CoM, finger axes (a box's)
PAD_FRICTION = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling
# (centre, half-size) boxes in the finger frame; the pad's inner face is the plane y = 0.
FINGER_BOXES = (((0.0, 0.0076, 0.04525), (0.00875, 0.0076, 0.00925)),  # pad
                ((0.0, 0.0135, 0.018), (0.011, 0.009, 0.018)))  # knuckle
# How far the fingertips reach beyond the TCP (along the hand axis): 9.5 mm. A TCP this high
# above a surface brings the tips onto it.
TIP_BEYOND_TCP = (FINGER_ORIGIN_Z + FINGER_BOXES[0][0][2] + FINGER_BOXES[0][1][2]
                  - float(hand.F_T_NE_HAND[2, 3]))

# The fingers touch the environment only (objects, the table), never their arm or each other: a
# bit of their own that no arm geom accepts, and conaffinity with the environment's bit alone.
FINGER_COLLISION_BITS = (TOOL_BIT, 1)
# Pad contacts: hard and grippy enough that a squeeze of tens of newtons neither sinks the pads
# into the object (MuJoCo's default contact would, by centimetres) nor lets a held cube creep.
PAD_SOLREF = (0.002, 1.0)
PAD_SOLIMP = (0.99, 0.999, 0.0005, 0.5, 2.0)
# The pads grip with the hard pad contact: a squeeze moves a finger, a light body, which the
# arm's soft contact would let sink by millimetres. So each finger's tip end (its last
# SOLE_THICKNESS, where it meets a table) is a geom of its own, the sole, with the arm's
# contact; the pad above it meets a table only under a press far over the collision thresholds.
SOLE_THICKNESS = 0.002  # m

FINGER_ARMATURE = 0.1  # kg along the stroke: the drive's reflected inertia (our choice)
# The mechanism that mirrors the fingers: N/m and N·s/m on the difference of the two finger
# positions. 1 N of off-centre load (a cube dragged over the table) leaves 50 µm of asymmetry;
# the relative mode (ω·dt ≈ 0.8, damping ratio 0.7) is well inside the 1 kHz explicit bound.
COUPLING_KP = 20_000.0
COUPLING_KD = float(0.7 * 2.0 * np.sqrt(COUPLING_KP * (FINGER_MASS + FINGER_ARMATURE)))
FINGER_KP = 3000.0  # N/m per finger
# Critical damping, N·s/m; a Python float, as the drive's per-step arithmetic is on scalars.
FINGER_KD = float(2.0 * np.sqrt(FINGER_KP * (FINGER_MASS + FINGER_ARMATURE)))
MAX_FINGER_FORCE = 100.0  # N per finger (the URDF effort limit: docs/figures.md, "The Franka Hand")


@dataclass(frozen=True)
class FingerCommand:
    """What the Hand's finger drive does during one step, in terms of the opening.

    Both fingers track `width` (each half of it) with feed-forward `speed` (d width/dt), each
    pushing with at most `force` N — the squeeze a grasped object feels.
    """

    width: float  # m
    speed: float  # m/s
    force: float  # N


@dataclass(frozen=True)
class FingerState:
    """The Hand's finger sensors after a step."""

    width: float  # m, between the pads
    speed: float  # m/s, d width/dt
    force: float  # N, mean drive force towards closing (the fingers' own weight excluded)


def finger_frames() -> tuple[np.ndarray, np.ndarray]:
    """(positions (2,3), rotations (2,3,3)) of the finger frames in the hand body (flange) frame,
    at joint position 0."""
    ne = np.asarray(hand.F_T_NE_HAND)[:3, :3]
    half_turn = np.diag([-1.0, -1.0, 1.0])
    rotations = np.stack([ne, ne @ half_turn])
    positions = np.tile([0.0, 0.0, FINGER_ORIGIN_Z], (2, 1))
    return positions, rotations


def _spread(d: np.ndarray) -> np.ndarray:
    """Parallel-axis term S(d) = |d|²·1 − d·dᵀ."""
    return float(d @ d) * np.eye(3) - np.outer(d, d)


# The palm is evaluated on {-1, 0, 1}² and fitted by least squares (exact: its CoM is linear
# and its inertia quadratic in x1, x2). The grid is fixed, so its least-squares solve is a
# constant: pinv of the rows [1, a, b, a², b², a·b], as LAPACK computes it, kept here bit for
# bit (recordings replay identically with it; tests/physics check it against np.linalg.pinv).
# A server thereby never runs an SVD, whose LAPACK code would stay resident (~0.7 MiB).
GRID = tuple((a, b) for a in (-1.0, 0.0, 1.0) for b in (-1.0, 0.0, 1.0))
GRID_SOLVE = np.array((
    (-0.11111111111111115, 0.22222222222222224, -0.1111111111111112,
     0.22222222222222224, 0.5555555555555557, 0.22222222222222224,
     -0.11111111111111124, 0.22222222222222215, -0.11111111111111124),
    (-0.16666666666666682, -0.16666666666666669, -0.16666666666666685,
     -1.7926136278042485e-16, 4.3866101946571197e-17, 1.2394888708219755e-18,
     0.1666666666666668, 0.1666666666666669, 0.16666666666666688),
    (-0.16666666666666674, -2.841246215602717e-17, 0.1666666666666667,
     -0.16666666666666663, 1.6077490589388233e-17, 0.1666666666666667,
     -0.16666666666666674, -2.5534684979433567e-17, 0.16666666666666674),
    (0.16666666666666632, 0.16666666666666652, 0.16666666666666682,
     -0.3333333333333335, -0.33333333333333337, -0.33333333333333315,
     0.1666666666666665, 0.1666666666666667, 0.1666666666666669),
    (0.16666666666666677, -0.3333333333333333, 0.16666666666666644,
     0.16666666666666669, -0.3333333333333334, 0.1666666666666664,
     0.166666666666667, -0.3333333333333332, 0.16666666666666657),
    (0.24999999999999908, -1.1344586431391537e-16, -0.24999999999999897,
     -8.389280121378032e-16, -9.714451465470136e-17, 1.200148754390375e-15,
     -0.25000000000000117, -2.2001930232302798e-16, 0.25000000000000094),
))


class Palm:
    """The hand body's own inertial such that palm + fingers = a given rigid composite.

    The palm's CoM is linear and its inertia quadratic in the two finger positions, so both are
    kept as polynomial coefficients (exact: a polynomial of degree 2 is fixed by its values on
    {-1, 0, 1}²) and a rewrite per step costs two small dot products and one 3×3 eigensolve.
    """

    def __init__(self, mass: float, com, inertia) -> None:
        positions, rotations = finger_frames()
        self._com_at_zero = positions + rotations @ FINGER_COM  # finger CoMs in F at x = 0
        self._opening_dir = rotations[:, :, 1]  # each finger's +y (its opening) in F
        self._finger_inertia = sum(R @ FINGER_INERTIA @ R.T for R in rotations)
        self._eigval, self._eigvec, self._inertia = np.zeros(3), np.zeros(9), np.zeros(9)
        self._monomials = np.ones(6)
        self.set_composite(mass, com, inertia)

    def set_composite(self, mass: float, com, inertia) -> None:
        """The rigid body palm + fingers must be: mass, CoM in F, inertia about the CoM (F axes)."""
        self.total_mass = float(mass)
        self.total_com = np.asarray(com, float).copy()
        self.total_inertia = np.asarray(inertia, float).reshape(3, 3).copy()
        self.mass = self.total_mass - 2 * FINGER_MASS
        if self.mass <= 0.0:
            raise ValueError(f"an end effector of {mass} kg cannot carry the Hand's fingers")
        # Coefficients of [1, x1, x2, x1², x2², x1·x2] from exact evaluations on GRID.
        values = [self.inertial(a, b) for a, b in GRID]
        self._com_coeffs = GRID_SOLVE @ np.array([v[0] for v in values])  # (6, 3)
        self._inertia_coeffs = GRID_SOLVE @ np.array([v[1].ravel() for v in values])  # (6, 9)

    def inertial(self, x1: float, x2: float) -> tuple[np.ndarray, np.ndarray]:
        """(CoM in F, inertia about it in F axes) of the palm for finger positions x1, x2."""
        c = self.total_com
        r1 = self._com_at_zero[0] + x1 * self._opening_dir[0]
        r2 = self._com_at_zero[1] + x2 * self._opening_dir[1]
        com = (self.total_mass * c - FINGER_MASS * (r1 + r2)) / self.mass
        inertia = (self.total_inertia - self._finger_inertia
                   - FINGER_MASS * (_spread(r1 - c) + _spread(r2 - c))
                   - self.mass * _spread(com - c))
        return com, inertia

    def slot(self, model: mujoco.MjModel, body: int) -> tuple[np.ndarray, ...]:
        """The model's inertial fields of the hand body, as the views `write` stores into
        (each model attribute access builds a new view: this runs every step the fingers move)."""
        return (model.body_iquat[body], model.body_mass[body:body + 1], model.body_ipos[body],
                model.body_inertia[body])

    def write(self, slot: tuple[np.ndarray, ...], x1: float, x2: float) -> None:
        """Store the palm for finger positions x1, x2 into the hand body's `slot`."""
        iquat, mass, ipos, body_inertia = slot
        k = self._monomials
        k[1], k[2], k[3], k[4], k[5] = x1, x2, x1 * x1, x2 * x2, x1 * x2
        # np.dot: the very BLAS call `@` makes here (the same bits), with less dispatch and
        # into a given array.
        inertia = np.dot(k, self._inertia_coeffs, out=self._inertia)
        mujoco.mju_eig3(self._eigval, self._eigvec, iquat, inertia)
        if min(self._eigval.tolist()) <= 0.0:
            raise ValueError("the fingers outweigh the end effector's inertia")
        mass[0] = self.mass
        np.dot(k, self._com_coeffs, out=ipos)
        body_inertia[:] = self._eigval


def _clip(f: float, limit: float) -> float:
    return limit if f > limit else (-limit if f < -limit else f)


def opening(width: float | None = None) -> float:
    """The fingers' opening a reset leaves (None: open), each finger at half of it."""
    return OPEN_WIDTH if width is None else float(width)


class Fingers:
    """One Hand's two finger joints in the world's data: their drive, their standstill and the
    palm that keeps palm + fingers the reported end effector.

    `gravity` is the world's g(q) vector (all dofs), of which the fingers take their own part.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, gravity: np.ndarray,
                 prefix: str, hand_body: int) -> None:
        jids = [model.joint(prefix + name).id for name in FINGER_JOINTS]
        qadr = [int(a) for a in model.jnt_qposadr[jids]]
        vadr = [int(a) for a in model.jnt_dofadr[jids]]
        if qadr[1] != qadr[0] + 1 or vadr[1] != vadr[0] + 1:
            raise RuntimeError("finger joints must be contiguous in qpos/qvel")
        fq, fv = slice(qadr[0], qadr[0] + 2), slice(vadr[0], vadr[0] + 2)
        self._qadr = qadr[0]
        self._q, self._v = data.qpos[fq], data.qvel[fv]
        self._applied, self._gravity = data.qfrc_applied[fv], gravity[fv]
        self._palm = Palm(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
        self._palm_slot = self._palm.slot(model, hand_body)
        self._palm_at: list[float] | None = None  # finger positions the palm is for
        self.command = FingerCommand(OPEN_WIDTH, 0.0, MAX_FINGER_FORCE)
        self._drive = (0.0, 0.0)

    def drive(self, command: FingerCommand | None) -> None:
        """Finger forces for this step: a force-limited PD on each finger plus its gravity load.
        `command` replaces the last one; None keeps it."""
        if command is not None:
            self.command = command
        c = self.command
        target, velocity = 0.5 * c.width, 0.5 * c.speed
        limit = max(0.0, min(c.force, MAX_FINGER_FORCE))
        (x1, x2), (v1, v2) = self._q.tolist(), self._v.tolist()
        f = _clip(FINGER_KP * (target - 0.5 * (x1 + x2))
                  + FINGER_KD * (velocity - 0.5 * (v1 + v2)), limit)
        mirror = COUPLING_KP * (x2 - x1) + COUPLING_KD * (v2 - v1)  # 0 when mirrored
        g1, g2 = self._gravity.tolist()
        self._applied[0], self._applied[1] = f + mirror + g1, f - mirror + g2
        self._drive = (f, f)

    def settle(self, command: FingerCommand | None, band: float) -> bool:
        """A finger within `band` of a standing command's opening, and slower than `band`, is
        put exactly there, at rest. True if a position changed."""
        c = command or self.command
        if c.speed != 0.0:
            return False
        moved = False
        target, fq, fv = 0.5 * c.width, self._q, self._v
        for i, (x, v) in enumerate(zip(fq.tolist(), fv.tolist())):
            if abs(x - target) < band and abs(v) < band:
                moved = moved or x != target
                fq[i], fv[i] = target, 0.0
        return moved

    def after_integration(self) -> None:
        """Rewrite the palm for the fingers' new positions, so the hand stays the reported body."""
        x = self._q.tolist()
        if x != self._palm_at:
            self._palm.write(self._palm_slot, *x)
            self._palm_at = x

    def reading(self) -> FingerState:
        (x1, x2), (v1, v2) = self._q.tolist(), self._v.tolist()
        f1, f2 = self._drive
        return FingerState(width=x1 + x2, speed=v1 + v2, force=-0.5 * (f1 + f2))

    def placed(self, width: float | None = None) -> dict[int, float]:
        half = 0.5 * opening(width)
        return {self._qadr: half, self._qadr + 1: half}

    def place(self, width: float | None = None) -> None:
        """Open (or `width` apart), at rest, commanded to stay so, the palm matching (in freshly
        reset data)."""
        width = opening(width)
        self._q[:] = 0.5 * width
        self._v[:] = 0.0
        self.command = FingerCommand(width, 0.0, MAX_FINGER_FORCE)
        self._drive = (0.0, 0.0)
        self._palm_at = None
        self.after_integration()

    def hold(self) -> None:
        """Their gravity load alone, as the drive at rest (g(q) must be current)."""
        self._applied[:] = self._gravity

    def body_placed(self, body: int) -> None:
        pass  # the fingers hold by contact alone: a body placed away has left them

    def set_composite(self, mass: float, com, inertia) -> None:
        """Palm + fingers become the given rigid body (mass, CoM in F, inertia about it)."""
        self._palm.set_composite(mass, com, inertia)
        self._palm_at = None
        self.after_integration()


class FingersMount:
    """The Hand's fingers as a tool on an arm (physics/tool.py ToolMount)."""

    def build(self, spec, hand_body, prefix: str, bits: tuple[int, int]) -> None:
        """Palm inertial (composite minus open fingers) and the two finger bodies with their
        joints (the coupling that mirrors them is the drive's)."""
        half = OPEN_WIDTH / 2
        palm = Palm(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
        set_inertial(hand_body, palm.mass, *palm.inertial(half, half))
        contype, conaffinity = FINGER_COLLISION_BITS
        contype, conaffinity = contype | bits[0], conaffinity | bits[1]
        positions, rotations = finger_frames()
        (pad_centre, pad_half), knuckle = FINGER_BOXES
        t = SOLE_THICKNESS / 2  # the pad's tip end (+z) becomes the sole
        boxes = {"collision0": ((pad_centre[0], pad_centre[1], pad_centre[2] - t),
                                (pad_half[0], pad_half[1], pad_half[2] - t)),
                 "collision1": knuckle,
                 "sole": ((pad_centre[0], pad_centre[1], pad_centre[2] + pad_half[2] - t),
                          (pad_half[0], pad_half[1], t))}
        for k, (body_name, joint_name) in enumerate(zip(FINGER_BODIES, FINGER_JOINTS)):
            body = hand_body.add_body(name=prefix + body_name, pos=positions[k],
                                      quat=quat(rotations[k]))
            set_inertial(body, FINGER_MASS, FINGER_COM, FINGER_INERTIA)
            body.add_joint(name=prefix + joint_name, type=mujoco.mjtJoint.mjJNT_SLIDE,
                           axis=[0, 1, 0], range=[0.0, FINGER_STROKE],
                           limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=FINGER_ARMATURE,
                           damping=0.0, frictionloss=0.0, solref_limit=PAD_SOLREF,
                           solimp_limit=PAD_SOLIMP)  # a hard stop
            for suffix, (centre, half_size) in boxes.items():
                pad = suffix == "collision0"
                body.add_geom(name=f"{prefix}{body_name}_{suffix}",
                              type=mujoco.mjtGeom.mjGEOM_BOX, pos=centre, size=half_size,
                              contype=contype, conaffinity=conaffinity, condim=4,
                              friction=PAD_FRICTION,
                              priority=1 if pad else ARM_CONTACT_PRIORITY,
                              solref=PAD_SOLREF if pad else ARM_CONTACT_SOLREF,
                              solimp=PAD_SOLIMP if pad else ARM_CONTACT_SOLIMP,
                              rgba=[0.3, 0.3, 0.3, 1.0])

    def attach(self, model, data, gravity, prefix: str, hand_body: int) -> "Fingers":
        return Fingers(model, data, gravity, prefix, hand_body)


FINGERS = FingersMount()
