"""The load a client declares with SetLoad: part of the robot's model, not of the world.

Its gravity torque J_Cᵀ·(−m·g) is added to the drive on top of g(q), so a load that is really
carried (a grasped object) holds still, and one that is not pushes the arm up against the joint
impedance, as on the robot. Its gravity and inertia are subtracted from the external torque, as
the robot subtracts its model.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.physics.backend import Payload
from franka_sim.spatial import cross3


class DeclaredLoad:
    """The declared load of the arm whose dofs are `vs`, carried at the flange site `site`."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, scratch: mujoco.MjData,
                 vs: slice, site: int) -> None:
        self._model, self._data, self._scratch, self._vs, self._site = (
            model, data, scratch, vs, site)
        self._body = int(model.site_bodyid[site])
        self._timestep = float(model.opt.timestep)
        self._flange_pos, self._flange_mat = data.site_xpos[site], data.site_xmat[site]
        self._dq = data.qvel[vs]
        self._gravity_vector = model.opt.gravity.copy()
        self._zero3 = np.zeros(3)
        self._generalized = np.zeros(model.nv)
        self.gravity = np.zeros(7)  # the declared load's g(q), added to the drive this step
        self._twist = np.zeros(6)  # [v_C; ω] of the load at the last step that carried it

    def prepare(self, load: Payload) -> None:
        """g(q) of the load into `gravity`, on the scratch kinematics at q (just computed)."""
        s, f, gen = self._scratch, self._site, self._generalized
        point = s.site_xpos[f] + s.site_xmat[f].reshape(3, 3) @ load.F_x_C
        gen[:] = 0.0
        mujoco.mj_applyFT(self._model, s, -load.mass * self._gravity_vector, self._zero3, point,
                          self._body, gen)  # Jᵀ·(the force that holds it up)
        self.gravity[:] = gen[self._vs]

    def subtract(self, tau_ext: np.ndarray, load: Payload, jac: np.ndarray,
                 carried: bool) -> None:
        """Take the load's gravity and inertia out of tau_ext. `jac`: the (6, nv) flange
        Jacobian at the new q; `carried`: the step before this one declared the same load."""
        tau_ext -= self.gravity
        tau_ext -= self._inertia_torque(load, jac[:, self._vs].copy(), carried)

    def _inertia_torque(self, load: Payload, J_F: np.ndarray, carried: bool) -> np.ndarray:
        """(7,) torque that accelerates the declared load over the step just taken.

        Its CoM velocity and angular velocity are differenced across steps, which is exactly the
        mean acceleration over the step (the interval ddq and the constraint force refer to).
        """
        R = self._flange_mat.reshape(3, 3)
        r = R @ load.F_x_C
        twist = J_F @ self._dq  # flange [v; ω]
        omega = twist[3:]
        twist[:3] += cross3(omega, r)  # the CoM's velocity
        previous, self._twist = self._twist, twist
        if not carried:
            return np.zeros(7)
        acceleration = (twist - previous) / self._timestep
        I_world = R @ load.inertia @ R.T
        torque = I_world @ acceleration[3:] + cross3(omega, I_world @ omega)
        gen = self._generalized
        gen[:] = 0.0
        mujoco.mj_applyFT(self._model, self._data, load.mass * acceleration[:3], torque,
                          self._flange_pos + r, self._body, gen)
        return gen[self._vs]
