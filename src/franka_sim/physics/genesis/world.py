"""A Genesis world: the arm, its Hand and the scene, loaded from the very MJCF the MuJoCo engine
compiles (physics/scene.py world_mjcf), one 1 ms Genesis step per cycle.

One arm. The world is one Genesis scene holding one entity: the document the MuJoCo engine
builds (the arm from its description, the Hand's fingers, the scene's table and objects), so
both engines simulate the same description. Each step the arm turns its command into joint
torques (physics/drive.py's law, with g(q) and the feed-forward from Genesis's own solver), the
world hands them to Genesis, steps, and reads the new state back.

Rest. A step whose inputs are the last step's, after two steps in which no joint of the arm or
its tool moved faster than SETTLE and no other faster than REST_SPEED, is not taken: the world
is asleep (as MuJoCo's resting bodies sleep; an arm holding still is put exactly on its hold as
it falls asleep), and the arm hands back its last readings, which the robot takes as "at rest".
Anything done to the world (a new command, a push, a placed body, a reset) wakes it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from franka_sim.physics.drive import SETTLE
from franka_sim.physics.bodies import Bodies, BodyState, UnknownBody
from franka_sim.physics.fingers import FINGER_JOINTS, FingersMount, opening
from franka_sim.physics.intrusions import Intrusion, intrusions, subtree
from franka_sim.physics.genesis.arm import GenesisArm
from franka_sim.physics.genesis.dynamics import (ArmDynamics, exact_inertials, flange_of,
                                                 quat_matrix)
from franka_sim.physics.genesis.runtime import genesis, write_mjcf
from franka_sim.physics.scene import GRAVITY, ArmPlacement, build_world_model, world_mjcf
from franka_sim.protocol.timing import CYCLE_PERIOD

REST_SPEED = 1e-5  # m/s and rad/s: a scene's body no faster, two steps running, is at rest


class GenesisBodies(Bodies):
    """The world's bodies by the MuJoCo model's names (the same document), their state read
    from Genesis; free_qpos addresses are those of `World.positions()`."""

    def __init__(self, model: mujoco.MjModel, entity) -> None:
        super().__init__(model, mujoco.MjData(model))
        self._entity = entity
        self._joint_of = {}  # a free body's joint in Genesis
        for name, _ in super().free_qpos():
            # (an unnamed joint: Genesis names it after its body)
            joint = model.joint(model.body(name).jntadr[0]).name or name
            self._joint_of[name] = entity.get_joint(joint)

    def free_qpos(self) -> list[tuple[str, int]]:
        return [(name, int(joint.qs_idx_local[0])) for name, joint in self._joint_of.items()]

    def link(self, name: str):
        return self._entity.get_link(self.find(name))


class GenesisWorld:
    """The Genesis scene of one arm (`placements`) in `scene`; not thread-safe."""

    def __init__(self, arms: Sequence[ArmPlacement], q0: Mapping[str, np.ndarray], *,
                 scene_xml=None) -> None:
        if len(arms) != 1 or arms[0].rides:
            raise ValueError("the Genesis engine simulates one arm standing on the world")
        gs = genesis()
        from genesis.utils.misc import qd_to_torch

        self._to_torch = qd_to_torch
        placement = arms[0]
        self.timestep = CYCLE_PERIOD
        self.model = build_world_model(arms, scene_xml=scene_xml)  # names, free bodies
        path = write_mjcf(world_mjcf(arms, scene_xml=scene_xml), "world")
        self.scene = gs.Scene(
            sim_options=gs.options.SimOptions(dt=CYCLE_PERIOD, substeps=1, gravity=GRAVITY),
            # Every pair of geoms MuJoCo's bits let touch, even those overlapping at q = 0
            # (Genesis would otherwise drop the arm's link5–hand pairs for good).
            rigid_options=gs.options.RigidOptions(enable_torsional_friction=True,
                                                  enable_neutral_collision=True),
            show_viewer=False)
        self.entity = entity = self.scene.add_entity(gs.morphs.MJCF(file=str(path)))
        self.scene.build()
        exact_inertials(entity, self.model)
        self._solver = self.scene.sim.rigid_solver
        prefix = placement.prefix
        names = [prefix + j.name for j in placement.desc.joints]
        if isinstance(placement.tool, FingersMount):
            names += [prefix + name for name in FINGER_JOINTS]
        self._dofs = [int(entity.get_joint(n).dofs_idx_local[0]) for n in names]
        self._others = np.setdiff1d(np.arange(entity.n_dofs), self._dofs)  # the scene's
        self._qs = [int(entity.get_joint(n).qs_idx_local[0]) for n in names]
        self._arm_qpos = [int(self.model.joint(n).qposadr[0]) for n in names[:7]]
        self._finger_qpos = [int(self.model.joint(n).qposadr[0]) for n in names[7:]]
        self._arm_tops = placement.tops
        dynamics = ArmDynamics(placement, names)
        self._arm = GenesisArm(placement, dynamics, self.timestep, len(names) - 7)
        self.arms = {placement.name: self._arm}
        self._hand = entity.get_link(prefix + "hand")
        self.bodies = GenesisBodies(self.model, entity)
        self._qpos0 = entity.get_qpos().cpu().numpy().copy()
        self._pushes: dict[int, list] = {}  # link index → [force, torque, steps left]
        self._still, self._asleep = 0, False
        self.reset(q0)

    # -- the hot path ---------------------------------------------------------------------------
    def step(self) -> None:
        arm, entity = self._arm, self.entity
        same = arm.same_inputs()
        if same and self._asleep and not self._pushes:
            return  # nothing would change (see Rest)
        self._asleep = False
        if arm.cmd.hold and arm.settle():
            entity.set_dofs_position(arm.q, self._dofs, zero_velocity=False)
            entity.set_dofs_velocity(arm.dq, self._dofs)
        arm.drive()
        entity.control_dofs_force(arm.applied, self._dofs)
        pushed = self._apply_pushes()
        self.scene.step()
        qpos = entity.get_qpos().cpu().numpy()
        qvel = entity.get_dofs_velocity().cpu().numpy()
        arm.q[:] = qpos[self._qs]
        arm.dq[:] = qvel[self._dofs]
        constraint = self._to_torch(self._solver.dyn_state.dofs.qf_constraint).cpu().numpy()
        arm.record(constraint.reshape(-1)[self._dofs[:7]], pushed, self._flange())
        self._still = self._still + 1 if same and self._is_still(qvel) else 0
        if self._still >= 2:
            self._fall_asleep()

    def _is_still(self, qvel: np.ndarray) -> bool:
        """No joint of the arm or its tool faster than SETTLE, no other faster than
        REST_SPEED."""
        others = self._others
        return (float(np.abs(qvel[self._dofs]).max()) < SETTLE
                and (not others.size or float(np.abs(qvel[others]).max()) < REST_SPEED))

    def _fall_asleep(self) -> None:
        """Asleep from now on; an arm holding still within SETTLE of its hold is put exactly
        there first (physics/arm.py, Standstill), so the frozen state is the hold's."""
        arm = self._arm
        if arm.cmd.hold and arm.settle():
            self.entity.set_dofs_position(arm.q, self._dofs, zero_velocity=False)
            self.entity.set_dofs_velocity(arm.dq, self._dofs)
            arm.record_settled(self._flange())
        self._asleep = True

    def finish_step(self) -> None:
        """Nothing: a Genesis step is done when step() returns."""

    def _flange(self):
        return flange_of(self.entity, self._hand, self._dofs[:7])

    def _apply_pushes(self) -> np.ndarray | None:
        """This step's pushes into Genesis (each at its body's centre of mass, world axes);
        their generalized force on the arm's dofs (None: no push)."""
        if not self._pushes:
            return None
        gs = genesis()
        on_arm = np.zeros(7)
        for link, push in list(self._pushes.items()):
            force, torque, left = push
            if left == 0:
                del self._pushes[link]
                continue
            push[2] = left - 1
            self.entity.apply_links_external_wrench(
                force[None], torque[None], links_idx_local=[link], ref=gs.link_ref_frame.link_COM)
            com = self.entity.get_links_pos(links_idx_local=[link],
                                            ref=gs.link_ref_frame.link_COM).cpu().numpy()[0]
            link_obj = self.entity.links[link]
            local = quat_matrix(*link_obj.get_quat().cpu().numpy().tolist()).T @ (
                com - link_obj.get_pos().cpu().numpy())
            J = self.entity.get_jacobian(link_obj, local_point=local).cpu().numpy()
            on_arm += J[:, self._dofs[:7]].T @ np.concatenate([force, torque])
        return on_arm

    # -- run-time changes -------------------------------------------------------------------------
    def reset(self, q0: Mapping[str, np.ndarray],
              tool_settings: Mapping[str, object] | None = None) -> None:
        """Everything as at the start, the arm at rest at its pose in `q0` (where it stands if
        not named), its tool at its start or at its setting; no push goes on."""
        arm = self._arm
        settings = tool_settings or {}
        if unknown := (set(settings) | set(q0)) - set(self.arms):
            raise KeyError(f"no arm named {sorted(unknown)}")
        q = np.asarray(q0.get(arm.name, arm.q[:7]), dtype=float)
        if q.shape != (7,):
            raise ValueError(f"q0 must have shape (7,), got {q.shape}")
        arm.place(q.copy(), settings.get(arm.name))
        qpos = self._qpos0.copy()
        qpos[self._qs] = arm.q
        self.entity.set_qpos(qpos, zero_velocity=True)
        self._settled()

    def reset_arm(self, name: str, q0, tool_setting: object | None = None) -> None:
        """The arm at rest at q0 (its tool at its start or `tool_setting`); the bodies as they
        are."""
        arm = self.arms[name]
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (7,):
            raise ValueError(f"q0 must have shape (7,), got {q0.shape}")
        arm.place(q0.copy(), tool_setting)
        self.entity.set_dofs_position(arm.q, self._dofs, zero_velocity=False)
        self.entity.set_dofs_velocity(np.zeros(len(self._dofs)), self._dofs)
        self._settled()

    def _settled(self) -> None:
        self._pushes.clear()
        self._still, self._asleep = 0, False
        self.entity.control_dofs_force(self._arm.applied, self._dofs)
        self._arm.record_rest(self._flange())

    def touching_arms(self) -> list[tuple[str, str]]:
        return []  # one arm

    def intrusions(self, name: str, q0, tool_setting: object | None = None) -> list[Intrusion]:
        """What the arm reset to q0 (the Hand open, or `tool_setting` apart) would be inside,
        the world as at its start (`reset`), on the MuJoCo model of the same document
        (physics/intrusions.py)."""
        qpos = self.model.qpos0.copy()
        qpos[self._arm_qpos] = q0
        if self._finger_qpos:
            qpos[self._finger_qpos] = 0.5 * opening(tool_setting)
        return intrusions(self.model, qpos, subtree(self.model, self._arm_tops))

    def positions(self) -> np.ndarray:
        """Every position of the world now (Genesis's qpos of the entity: a copy)."""
        return self.entity.get_qpos().cpu().numpy()

    def set_end_effector(self, arm: str, mass: float, com, inertia) -> None:
        raise NotImplementedError("the Genesis engine keeps the end effector as described")

    # -- what a test does to the world --------------------------------------------------------------
    def body_state(self, name: str) -> BodyState:
        link = self.bodies.link(name)
        return BodyState(link.get_pos().cpu().numpy().copy(),
                         link.get_quat().cpu().numpy().copy(),
                         link.get_vel().cpu().numpy().copy(),
                         link.get_ang().cpu().numpy().copy(),
                         self.bodies.is_free(self.bodies.find(name)))

    def place_body(self, name: str, position, quaternion=None) -> None:
        from franka_sim.physics.bodies import NotFree

        found = self.bodies.find(name)
        if not self.bodies.is_free(found):
            raise NotFree(found, self.bodies.why_fixed(self.bodies.id(found)))
        joint = self.bodies._joint_of[found]
        qs, dofs = list(joint.qs_idx_local), list(joint.dofs_idx_local)
        values = self.entity.get_qpos(qs).cpu().numpy().copy()
        values[:3] = position
        if quaternion is not None:
            quaternion = np.asarray(quaternion, dtype=float)
            values[3:7] = quaternion / np.linalg.norm(quaternion)
        # Inside: checked on the MuJoCo model of the same document, the world as it is
        self.bodies.placed(found, values[:3], values[3:7], self._mujoco_qpos())
        self.entity.set_qpos(values, qs, zero_velocity=False)
        self.entity.set_dofs_velocity(np.zeros(len(dofs)), dofs)
        self._still, self._asleep = 0, False

    def _mujoco_qpos(self) -> np.ndarray:
        """The world's positions now in the MuJoCo model's layout: the arm, its fingers and
        the free bodies (a scene's other joints as the model has them at rest)."""
        model, now = self.model, self.entity.get_qpos().cpu().numpy()
        qpos = model.qpos0.copy()
        qpos[self._arm_qpos + self._finger_qpos] = now[self._qs]
        for name, at in self.bodies.free_qpos():
            mujoco_at = model.jnt_qposadr[model.body(name).jntadr[0]]
            qpos[mujoco_at:mujoco_at + 7] = now[at:at + 7]
        return qpos

    def push(self, name: str, force, torque, steps: int) -> None:
        """As the MuJoCo world's (physics/world.py)."""
        if steps <= 0:
            raise ValueError(f"a push lasts at least one step, not {steps}")
        self.bodies.check_push(name, force, torque, steps * self.timestep)
        link = self.bodies.link(name).idx_local
        self._pushes[link] = [np.asarray(force, float), np.asarray(torque, float), steps]
        self._still, self._asleep = 0, False


__all__ = ["GenesisWorld", "REST_SPEED", "UnknownBody"]
