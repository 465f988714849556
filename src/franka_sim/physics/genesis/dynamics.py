"""An arm's dynamics at any q, computed by Genesis's own rigid solver on a scene of its own.

The world's scene is never disturbed: a second Genesis scene holds the arm and its tool alone
(the same MJCF, without the scene's objects and without collisions). A query puts that arm at
(q, dq), runs the solver's forward dynamics (no integration) and reads what it computed: the
joint-space inertia M(q) (rotor inertia included) and the bias force c(q, dq) + g(q), the very
terms the world's steps integrate with. g(q) is the bias at dq = 0. The fingers stand where the
world's are (they change the hand's composite, so g and M).
"""

from __future__ import annotations

import numpy as np

from franka_sim.physics.genesis.runtime import genesis, write_mjcf
from franka_sim.physics.scene import GRAVITY, ArmPlacement, build_world_model, world_mjcf
from franka_sim.protocol.timing import CYCLE_PERIOD


class ArmDynamics:
    """Queries on the arm of `placement` (its base at the world origin: the base frame's)."""

    def __init__(self, placement: ArmPlacement, joint_names: list[str]) -> None:
        gs = genesis()
        from genesis.utils.misc import qd_to_torch

        alone = ArmPlacement(placement.desc, tool=placement.tool, armature=placement.armature)
        path = write_mjcf(world_mjcf([alone]), f"arm-{placement.name or 'arm'}")
        model = build_world_model([alone])
        self._scene = scene = gs.Scene(
            sim_options=gs.options.SimOptions(dt=CYCLE_PERIOD, substeps=1, gravity=GRAVITY),
            rigid_options=gs.options.RigidOptions(enable_collision=False, enable_joint_limit=False,
                                                  enable_torsional_friction=True,
                                                  enable_neutral_collision=True),
            show_viewer=False)
        self._entity = entity = scene.add_entity(gs.morphs.MJCF(file=str(path)))
        scene.build()
        exact_inertials(entity, model)
        self._solver = scene.sim.rigid_solver
        self._to_torch = qd_to_torch
        # Every dof of the arm and its tool, in joint_names' order (the arm's 7 first).
        self._dofs = [int(entity.get_joint(name).dofs_idx_local[0]) for name in joint_names]
        self.n = len(self._dofs)
        self._q, self._dq = np.full(self.n, np.nan), np.zeros(self.n)  # as last set
        self._q_next = np.zeros(self.n)
        self._flange = entity.get_link("hand")
        self._gravity = np.asarray(GRAVITY, dtype=float)

    def _place(self, q, tool_q) -> None:
        """The arm's joints at q (its tool's at `tool_q`), the kinematics done; nothing is set
        again for the positions set last (a step asks g, then M and the bias, at one q)."""
        q_all = self._q_next
        q_all[:7] = q
        if tool_q is not None:
            q_all[7:] = tool_q
        if not np.array_equal(q_all, self._q):
            self._q[:] = q_all
            self._entity.set_dofs_position(self._q, self._dofs, zero_velocity=False)

    def _at(self, q, dq=None, tool_q=None) -> None:
        """The arm at (q, dq) (its tool's joints at `tool_q`, at rest), forward dynamics done."""
        self._place(q, tool_q)
        self._dq.fill(0.0)
        if dq is not None:
            self._dq[:7] = dq
        self._entity.set_dofs_velocity(self._dq, self._dofs)
        self._solver._func_forward_dynamics()  # M and the bias at this state; no step

    def _bias(self) -> np.ndarray:
        bias = self._to_torch(self._solver.dyn_state.dofs.qf_bias).cpu().numpy()
        return bias.reshape(-1)[self._dofs].copy()

    def gravity_all(self, q, tool_q=None) -> np.ndarray:
        """g of every dof (the arm's 7, then its tool's) at q."""
        self._at(q, None, tool_q)
        return self._bias()

    def bias_and_mass(self, q, dq, tool_q=None) -> tuple[np.ndarray, np.ndarray]:
        """(c(q, dq) + g(q) of the arm's dofs, M(q) of the arm's dofs with the rotors')."""
        self._at(q, dq, tool_q)
        M = self._entity.get_mass_mat().cpu().numpy()
        return self._bias()[:7], M[np.ix_(self._dofs[:7], self._dofs[:7])].copy()

    def load_gravity(self, q, tool_q, mass: float, F_x_C) -> np.ndarray:
        """(7,) torque that holds up `mass` at F_x_C in the flange frame, at q: Jᵀ·(−m·g) with
        the point's Jacobian from Genesis's kinematics."""
        self._place(q, tool_q)
        point = np.asarray(F_x_C, dtype=float)
        J = self._entity.get_jacobian(self._flange, local_point=point).cpu().numpy()
        return J[:3, self._dofs[:7]].T @ (-mass * self._gravity)

    def flange_pose_and_jacobian(self, q, tool_q=None) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F (4,4) and the flange Jacobian (6,7), rows [linear; angular], at q."""
        self._place(q, tool_q)
        return flange_of(self._entity, self._flange, self._dofs[:7])


def exact_inertials(entity, model) -> None:
    """The mass, centre of mass and inertia of every link of an arm (and its tool) as MuJoCo
    compiled them (`model`, the same document): the MJCF text Genesis reads rounds them to six
    digits. (A free body's Genesis keeps: its frame is its centre of mass.) The inertia is
    written in the inertial frame Genesis took from the text, so that in the link's frame it is
    MuJoCo's to rounding."""
    import mujoco

    rotation = np.zeros(9)
    for link in entity.links:
        try:
            body = model.body(link.name).id
        except KeyError:
            continue
        if link.is_fixed or link.n_dofs > 1 or model.body_mass[body] <= 0.0:
            continue
        mujoco.mju_quat2Mat(rotation, model.body_iquat[body])
        R = rotation.reshape(3, 3)
        inertia = R @ np.diag(model.body_inertia[body]) @ R.T  # in the link's frame
        R_g = quat_matrix(*np.asarray(link.desc.inertial_quat, dtype=float).tolist())
        index = [link.idx_local]
        entity.set_links_mass([float(model.body_mass[body])], index)
        entity.set_links_COM(model.body_ipos[body][None], index)
        entity.set_links_inertia((R_g.T @ inertia @ R_g)[None], index)


def quat_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """The rotation of a unit quaternion (w, x, y, z)."""
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def flange_of(entity, link, dofs) -> tuple[np.ndarray, np.ndarray]:
    """The flange's pose (the hand body's frame is the flange's) and Jacobian at the entity's
    current kinematics, in the world frame."""
    pose = np.eye(4)
    pose[:3, 3] = link.get_pos().cpu().numpy()
    pose[:3, :3] = quat_matrix(*link.get_quat().cpu().numpy().tolist())
    J = entity.get_jacobian(link).cpu().numpy()[:, dofs]
    return pose, J
