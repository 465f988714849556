"""What an arm's sensors read after a step, assembled into one Measured per step.

Sensors. tau_J is the link-side torque of an elastic joint whose motor carries the rotor
inertia B: tau_J = tau_motor − B·ddq (at rest tau_J = g(q), libfranka's sign). The world applies
tau_motor − tau_f (the link-side friction, physics/friction.py), so tau_J is that plus tau_f. theta models the
joint elasticity with the stiffness K = 7000 Nm/rad inferred from the robot's own θ − q ≈ τ_J/7000
(docs/figures.md, "Joint elasticity and rotor inertia"); the elasticity is only reported, not
simulated (the joints are rigid here).

Layout. A step's readings are one work array: the 7-vectors as they are published (computed in
place), then what the gather picks the other fields from: the flange block and the sensor data.
Measured's arrays are then one allocation and one indexing per step, not one per field.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.description.urdf import ACCELEROMETER_BOTTOM, ACCELEROMETER_TOP, ArmDescription
from franka_sim.kernels import bind_readings
from franka_sim.physics.backend import Measured

# Nm/rad, inferred (docs/figures.md, "Joint elasticity and rotor inertia").
JOINT_STIFFNESS = 7000.0
# The 7-vectors sit in rows of 8 so that every field starts 16-byte aligned, as a freshly
# allocated array does: whatever reads them sees the same memory alignment as with separate arrays.
_Q, _DQ, _DDQ, _TAU_J, _THETA, _DTAU_J, _DTHETA, _TAU_EXT = (
    slice(8 * i, 8 * i + 7) for i in range(8))
_TAU_J_THETA, _DTAU_J_DTHETA = slice(24, 39), slice(40, 55)  # each pair with a pad between
_ROWS = 64  # the 7-vectors
_O_T_F, _J_F, _TOP, _BOTTOM = slice(64, 80), slice(80, 122), slice(122, 140), slice(140, 158)
_READINGS = 158


class FlangeBlock:
    """The flange's pose and Jacobian as MuJoCo gives them, in a block of a work array, and the
    gather that makes O_T_F (4,4) and J_F (6,7) of them: both fresh, from one indexing.

    The block holds the site's xmat (9) and xpos (3), O_T_F's last row [0, 0, 0, 1] and the full
    (6, nv) Jacobian ([linear; angular], what mj_jacSite writes into `jacp` and `jacr`).
    """

    def __init__(self, work: np.ndarray, start: int, nv: int, dof: int) -> None:
        mat, pos, self.last_row, jac = start, start + 9, start + 12, start + 16
        self.mat, self.pos = work[mat:pos], work[pos:self.last_row]
        work[self.last_row:jac] = (0.0, 0.0, 0.0, 1.0)
        self.jac = work[jac:jac + 6 * nv].reshape(6, nv)
        self.jacp, self.jacr = self.jac[:3], self.jac[3:]
        O_T_F = [mat, mat + 1, mat + 2, pos, mat + 3, mat + 4, mat + 5, pos + 1,
                 mat + 6, mat + 7, mat + 8, pos + 2, *range(self.last_row, jac)]
        J_F = jac + nv * np.arange(6)[:, None] + dof + np.arange(7)
        self.index = np.concatenate([O_T_F, J_F.ravel()])  # J_F at 16: 16-byte aligned
        self._mat33 = self.mat.reshape(3, 3)

    def to_base(self, base: tuple[np.ndarray, np.ndarray]) -> None:
        """Express the block in the arm's base frame, given as (R, p) in the world frame."""
        R, p = base
        self._mat33[:] = R.T @ self._mat33
        self.pos[:] = R.T @ (self.pos - p)
        self.jacp[:] = R.T @ self.jacp
        self.jacr[:] = R.T @ self.jacr

    @staticmethod
    def size(nv: int) -> int:
        return 16 + 6 * nv


class Readings:
    """One arm's readings: the work array, its views (the arm computes ddq and tau_ext into
    them) and `record`, which makes the Measured of the step just taken. `base`: the arm's
    base frame (R, p) in the world frame, None if they are the same."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, desc: ArmDescription,
                 prefix: str, qs: slice, vs: slice, flange: int,
                 base: tuple[np.ndarray, np.ndarray] | None = None,
                 friction: np.ndarray | None = None) -> None:
        nv = model.nv
        sensors = _ROWS + FlangeBlock.size(nv)
        self._work = work = np.zeros(sensors + model.nsensordata)
        self._flange = block = FlangeBlock(work, _ROWS, nv, vs.start)
        self.jac = block.jac  # (6, nv) flange Jacobian at the new q, world frame till record
        self._work_sensors = work[sensors:]
        # Accelerometers: (top, bottom) × joints 1..6 × xyz; a sensor the description lacks
        # reads a 0 of O_T_F's last row.
        acc = np.full((2, 6, 3), block.last_row)
        for k, names in enumerate((ACCELEROMETER_TOP, ACCELEROMETER_BOTTOM)):
            for i, name in enumerate(names):
                if name in desc.frames:
                    sensor = model.sensor(prefix + name).id
                    acc[k, i] = sensors + model.sensor_adr[sensor] + np.arange(3)
        self._gather = np.concatenate([np.arange(_ROWS), block.index, acc.ravel()])
        assert self._gather.size == _READINGS
        self._work_q, self._work_dq = work[_Q], work[_DQ]
        self.ddq, self._tau_J, self._theta = work[_DDQ], work[_TAU_J], work[_THETA]
        self._tau_J_theta, self._derivatives = work[_TAU_J_THETA], work[_DTAU_J_DTHETA]
        self.tau_ext = work[_TAU_EXT]
        self._previous = np.zeros(15)  # the last step's tau_J and theta (views of its readings)
        # Where the readings come from: views into MjData (its buffers never move).
        self._model, self._data, self._site, self._base = model, data, flange, base
        self._q, self._dq, self._applied = data.qpos[qs], data.qvel[vs], data.qfrc_applied[vs]
        self._flange_mat, self._flange_pos = data.site_xmat[flange], data.site_xpos[flange]
        self._sensordata = data.sensordata
        self._armature = model.dof_armature[vs].copy()
        self._friction = np.zeros(7) if friction is None else friction  # applied as −tau_f
        # Divisors as arrays: a ufunc converts a Python scalar operand on every call.
        self._timesteps = np.full(15, float(model.opt.timestep))  # dtau_J, dtheta (with a pad)
        self.timestep7 = self._timesteps[:7]
        self._stiffness = np.full(7, JOINT_STIFFNESS)
        # The step's arithmetic and copies in one call (kernels/: compiled where built).
        self._compute = bind_readings(
            work, self._applied, self._armature, self._friction, self._stiffness, self._q,
            self._dq, self._timesteps, self._flange_mat, self._flange_pos, self._sensordata,
            self.ddq, self._tau_J, self._theta, self._tau_J_theta, self._derivatives,
            self._work_q, self._work_dq, block.mat, block.pos, self._work_sensors,
            self._gather.tolist())

    def flange_jacobian(self) -> None:
        """The flange Jacobian at the current q into `jac` (the kinematics must be fresh)."""
        block = self._flange
        mujoco.mj_jacSite(self._model, self._data, block.jacp, block.jacr, self._site)

    def record(self, tool: object, *, first: bool = False) -> Measured:
        """The readings of the step just taken, as one fresh array the Measured's fields view.

        The drive torque is in qfrc_applied; ddq, tau_ext and the Jacobian in the work array.
        """
        r = np.empty(_READINGS)
        if self._base is None:
            self._compute(first, self._previous, r)
        else:  # the world's frame is not this arm's: the flange block turns before the gather
            self._compute(first, self._previous, None)
            self._flange.to_base(self._base)
            np.take(self._work, self._gather, out=r)
        self._previous = r[_TAU_J_THETA]
        return Measured(
            q=r[_Q], dq=r[_DQ], ddq=r[_DDQ], tau_J=r[_TAU_J], dtau_J=r[_DTAU_J], theta=r[_THETA],
            dtheta=r[_DTHETA], O_T_F=r[_O_T_F].reshape(4, 4),
            accelerometer_top=r[_TOP].reshape(6, 3), accelerometer_bottom=r[_BOTTOM].reshape(6, 3),
            tool=tool, tau_ext=r[_TAU_EXT], J_F=r[_J_F].reshape(6, 7))
