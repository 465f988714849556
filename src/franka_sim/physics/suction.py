"""The vacuum gripper's suction cup on the flange: where it seals, how hard it holds, when it
lets go (a tool mount: physics/tool.py; its device: robot/vacuum_gripper.py).

Geometry. One cup on the flange's axis, its lip's face at the Franka Hand's TCP (0.1034 m), so
a pre-move written for the Hand puts the lip where the fingertips' centre would be. The lip is
a thin square pad for contact; the seal is the round cup inscribed in it, CUP_RADIUS, and its
area is what the vacuum pulls on.

Seal. With the pump on, the cup seals on a free body whose flat face (a box's face, a
cylinder's cap) touches the lip square to the axis (within SEAL_TILT) and covers the whole cup.
While sealed, the air in the cup is the pump's to take out (EVACUATION_RATE towards the
setpoint) or the valve's to let in (VENT_RATE, a drop-off); with the pump idle a sealed cup
keeps its vacuum (no leak). A cup that does not seal holds no vacuum.

Hold. A sealed part is welded to the flange where it sealed (a MuJoCo weld, soft as the
solver makes it) and the cup's lip stops colliding, so the part moves with the arm and its
weight and inertia reach the arm's joints through the weld, as a grasped part's reach them
through the Hand's pads. After each step the weld's wrench on the part is held against what a
suction cup can give: the vacuum v pulls with at most F = v · CUP_AREA towards the lip; what
the part pulls away with (its weight, its inertia) leaves N = F − pull pressing it on the lip,
and N bounds the shear (LIP_FRICTION · N) and the moment (N · CUP_RADIUS: the lip's pressure
moving to its rim) the seal takes. Beyond any of them the part comes off: the weld goes, the
air rushes in, and the part falls free. The lip gives (LIP_TIME_CONSTANT), so the limits hold
the wrench averaged over that time, not a single step's peak; and while the part still rests
on something (the table, as a lift begins) that support shares the load, so the limits hold
from the step it leaves it. Venting the cup to ambient lets go the same way. A part that came
off must leave the lip before the cup seals on it again (it is falling away).

Simplified: the cup is rigid (no bellows), the seal is perfect or gone (no leak), the figures
are ours (docs/tools.md).
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
SEAL_GAP = 0.0015  # m: a face this far off the lip does not close the cup
SEAL_TILT = math.radians(10.0)  # a face more tilted than this to the axis does not seal
LIP_TIME_CONSTANT = 0.02  # s: the lip's give, over which a load's peaks spread
PA_PER_MBAR = 100.0
_FLAT = {int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CYLINDER)}
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_EQUALITY = int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
SEAL = "suction_seal"  # the weld's name (prefixed with the arm's)


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
    lost: str = ""  # why the last part came off, if it did ("vented": a drop-off)


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
    """One arm's cup in the world's data: its seal, the air in it and the hold on a part."""

    def __init__(self, model, data, prefix: str, hand_body: int) -> None:
        self._model, self._data, self._hand = model, data, hand_body
        self._lip = model.geom(prefix + "suction_cup").id
        self._bits = (int(model.geom_contype[self._lip]), int(model.geom_conaffinity[self._lip]))
        self._weld = model.equality(prefix + SEAL).id
        self._dt = float(model.opt.timestep)
        self._rows = np.zeros(0)  # scratch: the weld's rows of efc_force
        self._generalized = np.zeros(model.nv)
        self._wrench = np.zeros(6)  # the weld's on the part, about the lip, filtered
        self.command = SuctionCommand()
        self.vacuum, self._part, self._geom, self._pumping = 0.0, -1, -1, False
        self.lost = ""  # why the last part came off ("" while none did)
        self._torn = -1  # a part that came off and still touches the lip: no seal on it yet

    # -- the step ----------------------------------------------------------------------------
    def drive(self, command: SuctionCommand | None) -> None:
        if command is not None:
            self.command = command
        c = self.command
        if self._part < 0 and c.setpoint > 0.0 and not c.vent:
            self._seal(*self._lip_frame())
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
        if v <= 0.0 and c.vent:
            self._release("vented")

    def after_integration(self) -> None:
        """The weld's wrench on the part over the step just taken against what the vacuum
        holds (the constraint rows are still those the step used)."""
        if self._part < 0 or self.vacuum <= 0.0:
            return
        reason = self._overloaded()
        if reason:
            self._torn = self._part
            self._release(reason)

    def _lip_frame(self) -> tuple[np.ndarray, np.ndarray]:
        d, h = self._data, self._hand
        R = d.xmat[h].reshape(3, 3)
        return d.xpos[h] + R[:, 2] * CUP_FACE_Z, R[:, 2].copy()

    def _seal(self, point: np.ndarray, axis: np.ndarray) -> None:
        m, d = self._model, self._data
        n, torn, self._torn = d.ncon, self._torn, -1
        for g1, g2 in zip(d.contact.geom1[:n].tolist(), d.contact.geom2[:n].tolist()):
            if self._lip not in (g1, g2):
                continue
            geom = g2 if g1 == self._lip else g1
            body = int(m.geom_bodyid[geom])
            if body == torn:  # it has to leave the lip before the cup seals on it again
                self._torn = torn
                continue
            if m.body_jntnum[body] != 1 or m.jnt_type[m.body_jntadr[body]] != _FREE:
                continue
            face = _face(m, d, geom, point, axis)
            if face is not None and face[1] < SEAL_GAP and face[2] >= 0.0:
                self._weld_to(body)
                self._part, self._geom, self.lost = body, geom, ""
                return

    def _weld_to(self, body: int) -> None:
        """The part held where it is now, relative to the flange."""
        m, d, h = self._model, self._data, self._hand
        Rh = d.xmat[h].reshape(3, 3)
        relative = np.zeros(4)
        mujoco.mju_mat2Quat(relative, (Rh.T @ d.xmat[body].reshape(3, 3)).ravel())
        m.eq_obj2id[self._weld] = body
        m.eq_data[self._weld, :3] = 0.0
        m.eq_data[self._weld, 3:6] = Rh.T @ (d.xpos[body] - d.xpos[h])
        m.eq_data[self._weld, 6:10] = relative
        m.eq_data[self._weld, 10] = 1.0  # torquescale
        d.eq_active[self._weld] = 1
        self._wrench[:] = 0.0
        m.geom_contype[self._lip] = m.geom_conaffinity[self._lip] = 0

    def _overloaded(self) -> str:
        """Why the seal cannot hold the weld's last wrench ("" if it can)."""
        m, d = self._model, self._data
        n = d.nefc
        rows = np.flatnonzero((d.efc_type[:n] == _EQUALITY) & (d.efc_id[:n] == self._weld))
        if rows.size == 0:
            return ""
        force = np.zeros(n)
        force[rows] = d.efc_force[rows]
        mujoco.mj_mulJacTVec(m, d, self._generalized, force)
        dof = int(m.jnt_dofadr[m.body_jntadr[self._part]])
        R = d.xmat[self._part].reshape(3, 3)
        point, axis = self._lip_frame()
        f = self._generalized[dof:dof + 3]  # on the part, world frame
        tau = R @ self._generalized[dof + 3:dof + 6] + np.cross(d.xpos[self._part] - point, f)
        blend = self._dt / (LIP_TIME_CONSTANT + self._dt)
        self._wrench += blend * (np.concatenate([f, tau]) - self._wrench)
        f, tau = self._wrench[:3], self._wrench[3:]
        if self._supported():  # it still rests on something: that takes what the cup does not
            return ""
        pull = -float(f @ axis)  # away from the lip is +axis
        holding = self.vacuum * PA_PER_MBAR * CUP_AREA
        pressed = holding - pull
        if pressed < 0.0:
            return f"pulled off ({pull:.1f} N, the vacuum holds {holding:.1f} N)"
        shear = float(np.linalg.norm(f + pull * axis))
        if shear > LIP_FRICTION[0] * pressed:
            return f"slid off ({shear:.1f} N sideways on {pressed:.1f} N pressing)"
        moment = float(np.linalg.norm(tau - (tau @ axis) * axis))
        if moment > pressed * CUP_RADIUS:
            return f"peeled off ({moment:.2f} Nm on {pressed:.1f} N pressing)"
        return ""

    def _supported(self) -> bool:
        """The part touches something (the lip does not collide while it holds)."""
        d, n, part = self._data, self._data.ncon, self._part
        bodies = self._model.geom_bodyid
        return any(bodies[g1] == part or bodies[g2] == part for g1, g2 in
                   zip(d.contact.geom1[:n].tolist(), d.contact.geom2[:n].tolist()))

    def _release(self, reason: str) -> None:
        m = self._model
        self._data.eq_active[self._weld] = 0
        m.geom_contype[self._lip], m.geom_conaffinity[self._lip] = self._bits
        self._part, self._geom, self.vacuum, self.lost = -1, -1, 0.0, reason

    # -- the rest of the tool seam -----------------------------------------------------------
    def settle(self, command: SuctionCommand | None, band: float) -> bool:
        return False  # nothing in the cup moves

    def reading(self) -> CupState:
        part = None if self._part < 0 else self._model.body(self._part).name
        return CupState(self.vacuum, self._part >= 0, self._pumping, part, self.lost)

    def placed(self, setting: object | None = None) -> dict[int, float]:
        return {}  # the cup has no joint: it is part of the flange's rigid body

    def place(self, setting: object | None = None) -> None:
        """Idle, open to the air, holding nothing (in freshly reset data)."""
        if self._part >= 0:
            self._release("")
        self._data.eq_active[self._weld] = 0
        self.command = SuctionCommand()
        self.vacuum, self._pumping, self.lost, self._torn = 0.0, False, "", -1

    def hold(self) -> None:
        pass  # the cup is part of the flange's rigid body: the arm's hold carries it

    def body_placed(self, body: int) -> None:
        """The part sealed on was put elsewhere: the weld goes and the air rushes in, as when
        a hand pulls a part off a cup (left welded, it was pulled back under the cup)."""
        if body == self._part:
            self._release("placed elsewhere")

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
        # The hold: a weld of the flange to a part, off until a seal makes it (its second body
        # is set then; the world's body stands in).
        spec.add_equality(type=mujoco.mjtEq.mjEQ_WELD, name=prefix + SEAL, name1=hand_body.name,
                          name2="world", objtype=mujoco.mjtObj.mjOBJ_BODY, active=False)

    def attach(self, model, data, gravity, prefix: str, hand_body: int) -> Cup:
        return Cup(model, data, prefix, hand_body)


CUP = CupMount()
