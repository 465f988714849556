"""What the environment does to one arm over a step, as the robot's external torque estimate.

It is exactly MuJoCo's constraint force on the arm's dofs (contacts of any arm, hand or finger
geom — a grasped object's weight reaches the arm through the finger pads — and any other
constraint that acts on it, another arm's push included) plus forces applied with xfrc_applied
(a viewer's perturbation, a test's push), minus the arm's own joint-limit stops, which are the
robot's, not the environment's. Finger-joint limits and the finger drive act on finger dofs
only and never reach it. It is reported in the robot's sign (what the robot exerts on the
environment: −that force); the declared load's model is subtracted by the arm
(physics/declared_load.py). Without contact it is exactly zero, at the cost of two checks.
"""

from __future__ import annotations

import mujoco
import numpy as np

_LIMIT_JOINT = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)


class ExternalTorque:
    """The external torque of the arm whose dofs are `vs` and joints `joints`, into `out`."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, vs: slice, joints,
                 out: np.ndarray) -> None:
        self._model, self._data, self._vs, self._out = model, data, vs, out
        self._constraint = data.qfrc_constraint[vs]
        self._xfrc = data.xfrc_applied
        self._arm_joint = np.zeros(model.njnt, dtype=bool)  # the arm's joints, by joint id
        self._arm_joint[joints] = True
        self._generalized = np.zeros(model.nv)

    def measure(self) -> np.ndarray:
        """(7,) torque the robot exerts on its environment over the step just integrated.

        Called between mj_step2 and mj_step1, while the constraint rows (efc_*) and the
        kinematics are still those the step used.
        """
        external = self._out
        touched, pushed = np.count_nonzero(self._constraint), np.count_nonzero(self._xfrc)
        if touched:
            external[:] = self._constraint
        else:
            external.fill(0.0)
            if not pushed:
                return external
        m, d, gen = self._model, self._data, self._generalized
        if touched:  # minus the arm's own joint-limit stops
            n = d.nefc
            rows = np.flatnonzero(d.efc_type[:n] == _LIMIT_JOINT)
            rows = rows[self._arm_joint[d.efc_id[rows]]]  # efc_id of a limit row: its joint
            if rows.size:
                force = np.zeros(n)
                force[rows] = d.efc_force[rows]
                mujoco.mj_mulJacTVec(m, d, gen, force)
                external -= gen[self._vs]
        if pushed:  # each pushed body's force and torque act at its centre of mass
            gen[:] = 0.0
            for body in np.flatnonzero(self._xfrc.any(axis=1)):
                wrench = self._xfrc[body]
                mujoco.mj_applyFT(m, d, wrench[:3], wrench[3:], d.xipos[body], int(body), gen)
            external += gen[self._vs]
        return np.negative(external, out=external)
