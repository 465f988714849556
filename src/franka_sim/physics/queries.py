"""An arm's kinematics and dynamics at a given q, computed on the world's scratch data.

The queries never disturb the state: they run on a second MjData, with every other body (other
arms, scene objects) where it is and at rest. Poses and Jacobians are in the arm's base frame.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.physics.readings import FlangeBlock
from franka_sim.spatial import jacobian_in_base, pose_in_base


class Queries:
    """Model queries for the arm whose joints are `qs` (qpos) / `vs` (dofs), flange site `site`
    and base frame `base` ((R, p) in the world frame; None: the world's)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, scratch: mujoco.MjData,
                 qs: slice, vs: slice, site: int,
                 base: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self._model, self._data, self._scratch, self._base = model, data, scratch, base
        self._qs, self._vs, self._site = qs, vs, site
        self._qpos, self._scratch_qpos = data.qpos, scratch.qpos
        self._scratch_arm_q = scratch.qpos[qs]
        self._scratch_flange_mat = scratch.site_xmat[site]
        self._scratch_flange_pos = scratch.site_xpos[site]
        self._work = np.zeros(FlangeBlock.size(model.nv))
        self._flange = FlangeBlock(self._work, 0, model.nv, vs.start)

    def _at(self, q, dq=None) -> mujoco.MjData:
        s = self._scratch
        s.qpos[:] = self._data.qpos  # everything else where it is
        s.qvel[:] = 0.0
        s.qpos[self._qs] = q
        if dq is not None:
            s.qvel[self._vs] = dq
        mujoco.mj_fwdPosition(self._model, s)
        mujoco.mj_fwdVelocity(self._model, s)
        return s

    def gravity(self, q) -> np.ndarray:
        return self._at(q).qfrc_bias[self._vs].copy()

    def coriolis(self, q, dq) -> np.ndarray:
        bias = self._at(q, dq).qfrc_bias[self._vs].copy()  # copy: gravity() reuses the scratch
        return bias - self.gravity(q)

    def mass_matrix(self, q, *, include_armature: bool = False) -> np.ndarray:
        s, nv = self._at(q), self._model.nv
        full = np.zeros((nv, nv))
        mujoco.mj_fullM(self._model, s, full)
        M = full[self._vs, self._vs].copy()
        if not include_armature:
            M[np.diag_indices(7)] -= self._model.dof_armature[self._vs]
        return M

    def jacobian_flange(self, q) -> np.ndarray:
        s, nv = self._at(q), self._model.nv
        jacp, jacr = np.zeros((3, nv)), np.zeros((3, nv))
        mujoco.mj_jacSite(self._model, s, jacp, jacr, self._site)
        J = np.vstack([jacp[:, self._vs], jacr[:, self._vs]])
        if self._base is not None:
            J = jacobian_in_base(J, self._base)
        return J

    def flange_pose(self, q) -> np.ndarray:
        """O_T_F at q computed by MuJoCo (for cross-checks against the numpy kinematics)."""
        s = self._at(q)
        pose = np.eye(4)
        pose[:3, :3] = s.site_xmat[self._site].reshape(3, 3)
        pose[:3, 3] = s.site_xpos[self._site]
        if self._base is not None:
            pose_in_base(pose, self._base)
        return pose

    def flange_pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F and the flange Jacobian at q from one kinematics pass (the desired-state path)."""
        m, s, block = self._model, self._scratch, self._flange
        self._scratch_qpos[:] = self._qpos
        self._scratch_arm_q[:] = q
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)  # what mj_jacSite needs, nothing more
        mujoco.mj_jacSite(m, s, block.jacp, block.jacr, self._site)
        block.mat[:] = self._scratch_flange_mat
        block.pos[:] = self._scratch_flange_pos
        if self._base is not None:
            block.to_base(self._base)
        r = self._work[block.index]
        return r[:16].reshape(4, 4), r[16:].reshape(6, 7)
