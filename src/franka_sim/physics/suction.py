"""The vacuum gripper's suction cup on the flange: where it seals, how hard it holds, when it
lets go (a tool mount: physics/tool.py; its device: robot/vacuum_gripper.py).

Geometry. One cup on the flange's axis, its lip's face at the Franka Hand's TCP (0.1034 m), so
a pre-move written for the Hand puts the lip where the fingertips' centre would be. The lip is
a thin square pad for contact (box–box contacts give MuJoCo a patch that holds a moment); the
seal is the round cup inscribed in it, CUP_RADIUS, and its area is what the vacuum pulls on.

Seal. With the pump on, the cup seals on a free body whose flat face (a box's face, a
cylinder's cap) touches the lip square to the axis (within SEAL_TILT) and covers the whole cup.
While sealed, the air in the cup is the pump's to take out (EVACUATION_RATE towards the
setpoint) or the valve's to let in (VENT_RATE, a drop-off); with the pump idle a sealed cup
keeps its vacuum (no leak). A cup that does not seal holds no vacuum.

Force. The vacuum v pulls the part towards the lip with F = v · CUP_AREA along the axis, and
the flange with −F: a pressure difference over the sealed area, no more. The lip's contact
carries the rest (the part's weight sideways through friction), so a part whose weight and
inertia ask more than F pulls away; once its face is SEAL_GAP off the lip, or tilted or slid
off the cup, air rushes in and the part is free. Both forces go through xfrc_applied, so the
arm's external torque (physics/external_torque.py) and its joint torques carry a held part's
load as they carry one the Hand grasps (through its pads).

Simplified: the cup is rigid (no bellows), the seal is perfect or gone, the figures below are
ours (docs/tools.md), and while a part is held its row of xfrc_applied is the suction's (a push
through the control API does not act on a held part).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from franka_sim.description import hand
from franka_sim.physics.arm_model import (ARM_CONTACT_PRIORITY, ARM_CONTACT_SOLIMP,
                                          ARM_CONTACT_SOLREF, TOOL_BIT, set_inertial,
                                          write_inertial)

CUP_FACE_Z = 0.1034  # m along the flange axis: the lip's face, at the Hand's TCP
CUP_TOP_Z = 0.084  # m: where the cup's body meets the flange-side housing
CUP_RADIUS = 0.01  # m: a 20 mm cup
CUP_AREA = math.pi * CUP_RADIUS ** 2  # m², the sealed area the vacuum pulls on
LIP_FRICTION = (1.0, 0.005, 0.0001)  # rubber on a part
MAX_VACUUM = 750.0  # mbar below ambient: the most the pump draws
EVACUATION_RATE = 2500.0  # mbar/s into a sealed cup (0.3 s to the most)
VENT_RATE = 5000.0  # mbar/s out of it on a drop-off
SEAL_GAP = 0.0015  # m: a part this far off the lip has let the air in
SEAL_TILT = math.radians(10.0)  # a face more tilted than this to the axis does not seal
PA_PER_MBAR = 100.0
_FLAT = {int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CYLINDER)}
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


@dataclass(frozen=True)
class SuctionCommand:
    """What the pump does: draw towards `setpoint` mbar (0: idle), or `vent` the cup."""

    setpoint: float = 0.0
    vent: bool = False


@dataclass(frozen=True)
class CupState:
    """The cup's sensor after a step."""

    vacuum: float  # mbar below ambient
    sealed: bool  # a part's face closes the cup
    pumping: bool  # the pump draws air (it has not reached its setpoint)
    part: str | None  # the body sealed on


def _face(model, data, geom: int, point: np.ndarray, axis: np.ndarray):
    """(normal of the flat face of `geom` facing the cup, gap from `point` to it, room: how
    far the cup's centre may slide on it before the lip overhangs), or None: no flat face
    square enough to the axis."""
    kind = int(model.geom_type[geom])
    if kind not in _FLAT:
        return None
    R, size = data.geom_xmat[geom].reshape(3, 3), model.geom_size[geom]
    local = R.T @ (point - data.geom_xpos[geom])
    if kind == int(mujoco.mjtGeom.mjGEOM_BOX):
        k = int(np.argmax(np.abs(R.T @ axis)))
        half, others = size[k], [size[i] - abs(local[i]) for i in range(3) if i != k]
        room = min(others)
    else:  # a cylinder's caps
        k, half = 2, size[1]
        room = size[0] - math.hypot(local[0], local[1])
    sign = 1.0 if local[k] >= 0.0 else -1.0
    normal = sign * R[:, k]  # out of the face the cup is on
    if float(normal @ -axis) < math.cos(SEAL_TILT):
        return None
    return normal, sign * local[k] - half, room - CUP_RADIUS


class Cup:
    """One arm's cup in the world's data: its seal, the air in it and the forces it makes."""

    def __init__(self, model, data, prefix: str, hand_body: int) -> None:
        self._model, self._data, self._hand = model, data, hand_body
        self._lip = model.geom(prefix + "suction_cup").id
        self._dt = float(model.opt.timestep)
        self.command = SuctionCommand()
        self.vacuum, self._part, self._geom, self._pumping = 0.0, -1, -1, False

    # -- the step ----------------------------------------------------------------------------
    def drive(self, command: SuctionCommand | None) -> None:
        if command is not None:
            self.command = command
        c, point, axis = self.command, *self._lip_frame()
        if self._part < 0 and c.setpoint > 0.0 and not c.vent:
            self._seal(point, axis)
        if self._part >= 0 and not self._holds(point, axis):
            self._release()
        if self._part < 0:
            self.vacuum, self._pumping = 0.0, c.setpoint > 0.0 and not c.vent
            return
        v = self.vacuum
        if c.vent:
            v = max(0.0, v - VENT_RATE * self._dt)
        elif c.setpoint > 0.0:
            goal = min(c.setpoint, MAX_VACUUM)
            step = (EVACUATION_RATE if goal > v else VENT_RATE) * self._dt
            v = min(goal, v + step) if goal > v else max(goal, v - step)
        self._pumping = c.setpoint > 0.0 and not c.vent and v < min(c.setpoint, MAX_VACUUM)
        self.vacuum = v
        if v <= 0.0:
            self._release()
        else:
            self._pull(point, axis)

    def _lip_frame(self) -> tuple[np.ndarray, np.ndarray]:
        d, h = self._data, self._hand
        R = d.xmat[h].reshape(3, 3)
        return d.xpos[h] + R[:, 2] * CUP_FACE_Z, R[:, 2].copy()

    def _seal(self, point: np.ndarray, axis: np.ndarray) -> None:
        m, d = self._model, self._data
        n = d.ncon
        for g1, g2 in zip(d.contact.geom1[:n].tolist(), d.contact.geom2[:n].tolist()):
            if self._lip not in (g1, g2):
                continue
            geom = g2 if g1 == self._lip else g1
            body = int(m.geom_bodyid[geom])
            if m.body_jntnum[body] != 1 or m.jnt_type[m.body_jntadr[body]] != _FREE:
                continue
            face = _face(m, d, geom, point, axis)
            if face is not None and face[1] < SEAL_GAP and face[2] >= 0.0:
                self._part, self._geom = body, geom
                return

    def _holds(self, point: np.ndarray, axis: np.ndarray) -> bool:
        face = _face(self._model, self._data, self._geom, point, axis)
        return face is not None and face[1] < SEAL_GAP and face[2] >= -CUP_RADIUS / 2

    def _pull(self, point: np.ndarray, axis: np.ndarray) -> None:
        d, force = self._data, self.vacuum * PA_PER_MBAR * CUP_AREA * axis
        for body, f in ((self._part, -force), (self._hand, force)):
            d.xfrc_applied[body, :3] = f
            d.xfrc_applied[body, 3:] = np.cross(point - d.xipos[body], f)

    def _release(self) -> None:
        if self._part >= 0:
            self._data.xfrc_applied[self._part] = 0.0
            self._data.xfrc_applied[self._hand] = 0.0
        self._part, self._geom, self.vacuum = -1, -1, 0.0

    # -- the rest of the tool seam -----------------------------------------------------------
    def settle(self, command: SuctionCommand | None, band: float) -> bool:
        return False  # nothing in the cup moves

    def after_integration(self) -> None:
        pass

    def reading(self) -> CupState:
        part = None if self._part < 0 else self._model.body(self._part).name
        return CupState(self.vacuum, self._part >= 0, self._pumping, part)

    def place(self, setting: object | None = None) -> None:
        """Idle, open to the air (in freshly reset data, whose xfrc_applied is zero)."""
        self.command = SuctionCommand()
        self.vacuum, self._part, self._geom, self._pumping = 0.0, -1, -1, False

    def hold(self) -> None:
        pass  # the cup is part of the flange's rigid body: the arm's hold carries it

    def set_composite(self, mass: float, com, inertia) -> None:
        write_inertial(self._model, self._hand, mass, com, np.asarray(inertia, float))


class CupMount:
    """The suction cup as a tool on an arm (physics/tool.py ToolMount): rigid on the flange,
    the flange's body keeping the reported end effector's inertial."""

    def build(self, spec, hand_body, prefix: str, bits: tuple[int, int]) -> None:
        set_inertial(hand_body, hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
        half_height = (CUP_FACE_Z - CUP_TOP_Z) / 2
        hand_body.add_geom(name=prefix + "suction_cup", type=mujoco.mjtGeom.mjGEOM_BOX,
                           pos=[0.0, 0.0, CUP_TOP_Z + half_height],
                           size=[CUP_RADIUS, CUP_RADIUS, half_height],
                           contype=TOOL_BIT | bits[0], conaffinity=1 | bits[1], condim=4,
                           friction=LIP_FRICTION, priority=ARM_CONTACT_PRIORITY,
                           solref=ARM_CONTACT_SOLREF, solimp=ARM_CONTACT_SOLIMP,
                           rgba=[0.2, 0.3, 0.8, 1.0])

    def attach(self, model, data, gravity, prefix: str, hand_body: int) -> Cup:
        return Cup(model, data, prefix, hand_body)


CUP = CupMount()
