"""The MuJoCo world: one model and data, its arms, and one 1 ms step per cycle for all of them.

Step structure. `mj_step2` then `mj_step1`: the second half of step n followed by the first
half of step n+1. After it, position-dependent quantities (flange pose, g(q)) belong to the new
q that we report, while accelerations (ddq, accelerometers) are those of the step just taken —
a sensor reports the acceleration over the interval it sampled. The readings need only the
kinematics of the new q (mj_kinematics, mj_comPos), so `step` computes those and leaves the
rest of mj_step1 (inertia, its factorisation, contacts, velocities, bias) and the next step's
gravity compensation to `finish_step`, which the server calls once the states have left: a
lockstep client waits for none of it. Whoever does not call it gets it done at the start of the
next step. Both orders run the same computations on the same inputs: the results are the same
bits.

Gravity compensation. g(q) of every arm comes from one recursive Newton–Euler pass, the very
one MuJoCo uses for its own bias force, at zero velocity: at rest the two cancel to the last
bit, which is what makes runs reproducible from a given pose.

Rest. When two consecutive steps changed nothing (state, warm start and inputs bit-identical
before and after, the scene's resting objects asleep), and the next step gets the same commands
and finds the data untouched, its result is known exactly: the same state and the same
readings. It is not recomputed; only the clock advances. An idle world then costs a comparison
per cycle instead of a step, and every published bit is what stepping would have given.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from franka_sim.physics.arm import Arm
from franka_sim.physics.bodies import Bodies, BodyState, Pushes
from franka_sim.physics.intrusions import Intrusion, contacts, intrusions, subtree
from franka_sim.physics.scene import ArmPlacement, build_world_model

# What a step reads and writes, except the clock: positions, velocities, warm start, inputs.
_REST_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION) & ~int(mujoco.mjtState.mjSTATE_TIME)


class World:
    """Owns the MjModel/MjData pair and the arms in it; not thread-safe (one owner thread).

    `q0` gives every arm's starting pose, by name. Each step uses the command each arm was
    last given (`Arm.command`); each arm's `measure()` then has its readings.
    """

    def __init__(self, arms: Sequence[ArmPlacement], q0: Mapping[str, np.ndarray], *,
                 scene_xml: str | os.PathLike | None = None) -> None:
        self.model = model = build_world_model(arms, scene_xml=scene_xml)
        self.timestep = float(model.opt.timestep)
        self.data = data = mujoco.MjData(model)
        self.scratch = mujoco.MjData(model)  # for queries, so they never disturb the state
        self._rne = np.zeros(model.nv)  # g(q) of all dofs (see _gravity_at_rest)
        self.arms = {p.name: Arm(model, data, self.scratch, self._rne, p) for p in arms}
        self._arms = tuple(self.arms.values())
        self.bodies = Bodies(model, data)
        self._pushes = Pushes(data)
        self._pushing = self._pushes.steps_left  # non-empty while a push is on
        self._qpos, self._scratch_qpos, self._scratch_qvel = (
            data.qpos, self.scratch.qpos, self.scratch.qvel)
        # A mocap body (the mobile base) where the data has it, for g(q) to match the bias.
        self._mocap = (data.mocap_pos, data.mocap_quat, self.scratch.mocap_pos,
                       self.scratch.mocap_quat) if model.nmocap else None
        # Rest detection: the data as a step found and left it (see the module docstring).
        size = mujoco.mj_stateSize(model, _REST_STATE)
        self._before, self._after, self._now = np.empty(size), np.empty(size), np.empty(size)
        self._asleep = data.tree_asleep.copy()
        self._still = 0  # consecutive steps that changed nothing
        self._unfinished = False  # the last step's mj_step1 is still to do (finish_step)
        self._prepared = False  # g(q) at the current q, each arm's load for arm.prepared_load
        if missing := set(self.arms) - set(q0):
            raise ValueError(f"no starting pose for arm(s) {sorted(missing)}")
        self.reset(q0)

    def positions(self) -> np.ndarray:
        """Every position of the world now (qpos: a view)."""
        return self.data.qpos

    @property
    def unfinished(self) -> bool:
        """The last step's mj_step1 (and next g(q)) is still to do (see finish_step)."""
        return self._unfinished

    @property
    def prepared(self) -> bool:
        """g(q) (and each arm's declared load's) is ready for a step at the current q."""
        return self._prepared

    # -- the hot path ---------------------------------------------------------------------------
    def step(self) -> None:
        """Advance every arm (and everything else) by one timestep, with each arm's command."""
        self.finish_step()
        if self._pushing:
            self._pushes.count_down()
        same = True
        for arm in self._arms:
            if not arm.same_inputs():
                same = False
        if same and self._still >= 2 and self._untouched():
            self.data.time += self.timestep  # the step mj_step would take, to the bit
            return
        if same:
            mujoco.mj_getState(self.model, self.data, self._before, _REST_STATE)
            self._asleep[:] = self.data.tree_asleep
        self._step()
        if same:  # rest detection compares whole steps (an idle hold: no client waits)
            self.finish_step()
            mujoco.mj_getState(self.model, self.data, self._after, _REST_STATE)
            still = (np.array_equal(self._before, self._after)
                     and np.array_equal(self._asleep, self.data.tree_asleep))
            self._still = self._still + 1 if still else 0
        else:
            self._still = 0

    def finish_step(self) -> None:
        """The rest of the last step: mj_step1 beyond the kinematics, and g(q) at the new q
        (for the load each arm's command declares: the next one almost always declares it too)."""
        if not self._unfinished:
            return
        self._unfinished = False
        mujoco.mj_step1(self.model, self.data)
        self._prepare_gravity()

    def _prepare_gravity(self) -> None:
        """g(q) at the current q: every arm's into self._rne, and the load each arm's command
        declares on the same scratch kinematics."""
        self._gravity_at_rest()
        for arm in self._arms:
            load = arm.prepared_load = arm.cmd.load
            if load is not None:
                arm.declared_load.prepare(load)
        self._prepared = True

    def forget_gravity(self) -> None:
        """Have the next step compute g(q) at its start, as if no finish_step had prepared it
        (both give the same bits: a check of that)."""
        self._prepared = False

    def _untouched(self) -> bool:
        """Nothing wrote into the data since the last step (a test's push, a reset)."""
        mujoco.mj_getState(self.model, self.data, self._now, _REST_STATE)
        return bool(np.array_equal(self._now, self._after)
                    and np.array_equal(self._asleep, self.data.tree_asleep))

    def _step(self) -> None:
        m, d, arms = self.model, self.data, self._arms
        prepared = self._prepared
        for arm in arms:
            cmd = arm.cmd
            if cmd.hold and arm.settle():
                prepared = False  # q moved: g(q) is recomputed (mj_step1 is not)
            if arm.prepared_load is not cmd.load:
                prepared = False
        if not prepared:
            self._prepare_gravity()
        self._prepared = False
        for arm in arms:
            arm.drive()
        mujoco.mj_step2(m, d)
        for arm in arms:
            arm.after_integration()  # before step1 rebuilds the constraint rows
        mujoco.mj_kinematics(m, d)  # what the readings need of mj_step1 (see finish_step)
        mujoco.mj_comPos(m, d)
        self._unfinished = True
        for arm in arms:
            arm.record()

    def _gravity_at_rest(self) -> None:
        """g(q) at the current q into self._rne, bit-identical to MuJoCo's bias at dq = 0.

        All four passes are needed: the queries leave the scratch at other positions and
        velocities, and even at dq = 0 mj_comVel's zeros carry signs that depend on q.
        """
        m, s = self.model, self.scratch
        self._scratch_qpos[:] = self._qpos
        self._scratch_qvel.fill(0.0)
        if self._mocap is not None:
            pos, quat, scratch_pos, scratch_quat = self._mocap
            scratch_pos[:] = pos
            scratch_quat[:] = quat
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)
        mujoco.mj_comVel(m, s)
        mujoco.mj_rne(m, s, 0, self._rne)

    # -- run-time changes -------------------------------------------------------------------------
    def reset(self, q0: Mapping[str, np.ndarray],
              tool_settings: Mapping[str, object] | None = None) -> None:
        """Everything back to the model's initial state, each arm at rest at its pose in `q0`
        (an arm not named there: where it stands), held by gravity compensation alone, so the
        sensors read rest values. An arm's tool is at its start, or at rest at the setting
        `tool_settings` gives for its arm (the Hand: its opening). No push goes on."""
        poses = {name: self.data.qpos[arm.qs].copy() for name, arm in self.arms.items()}
        settings = tool_settings or {}
        if unknown := set(settings) - set(self.arms):
            raise KeyError(f"no arm named {sorted(unknown)}")
        for name, q in q0.items():
            q = np.asarray(q, dtype=float)
            if q.shape != (7,):
                raise ValueError(f"q0 must have shape (7,), got {q.shape}")
            if name not in self.arms:
                raise KeyError(f"no arm named {name!r}")
            poses[name] = q
        m, d = self.model, self.data
        self._still = 0
        self._unfinished, self._prepared = False, False  # all is recomputed below
        mujoco.mj_resetData(m, d)
        self._pushes.clear()
        for arm in self._arms:
            arm.place(poses[arm.name], settings.get(arm.name))
        self._gravity_at_rest()
        for arm in self._arms:
            arm.hold_still()
        mujoco.mj_forward(m, d)  # qacc = 0 here: gravity compensation alone holds the arms
        for arm in self._arms:
            arm.record_rest()

    def reset_arm(self, name: str, q0, tool_setting: object | None = None) -> None:
        """One arm at rest at q0 (its tool at its start, or at `tool_setting`), held by gravity
        compensation alone; the other arms and the bodies are left as they are (a world of
        several arms, whose other clients may be at work)."""
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (7,):
            raise ValueError(f"q0 must have shape (7,), got {q0.shape}")
        arm = self.arms[name]
        self.finish_step()
        self._still = 0
        self._unfinished, self._prepared = False, False
        arm.place(q0, tool_setting)
        self.data.qvel[arm.vs] = 0.0
        self._gravity_at_rest()
        arm.hold_still()
        mujoco.mj_forward(self.model, self.data)
        arm.record_rest()

    def intrusions(self, name: str, q0, tool_setting: object | None = None) -> list[Intrusion]:
        """What arm `name` reset to q0 (its tool at its start, or at `tool_setting`) would be
        inside (physics/intrusions.py): the world as `reset` leaves it (one arm: the bodies
        where they started) or as it is (`reset_arm`, several: a mobile base where it drove).
        Nothing changes."""
        arm, d = self.arms[name], self.data
        alone = len(self._arms) == 1
        qpos = (self.model.qpos0 if alone else d.qpos).copy()
        qpos[arm.qs] = q0
        if arm.tool is not None:
            for address, value in arm.tool.placed(tool_setting).items():
                qpos[address] = value
        mocap = None if alone else (d.mocap_pos, d.mocap_quat)
        return intrusions(self.model, qpos, subtree(self.model, arm.tops), mocap)

    def touching_arms(self) -> list[tuple[str, str]]:
        """Pairs of arms whose bodies touch now (arms placed into each other), by name."""
        m, d = self.model, self.data
        mujoco.mj_forward(m, d)
        owner = {}
        for name in self.arms:
            prefix = f"{name}/"
            for body in range(m.nbody):
                if m.body(body).name.startswith(prefix):
                    owner[body] = name
        pairs = set()
        for body_a, body_b, _ in contacts(m, d):
            a, b = owner.get(body_a), owner.get(body_b)
            if a is not None and b is not None and a != b:
                pairs.add(tuple(sorted((a, b))))
        return sorted(pairs)

    def set_end_effector(self, arm: str, mass: float, com, inertia) -> None:
        """Replace the rigid body on an arm's flange (Hand + load): mass, CoM in F, inertia
        about CoM.

        Gravity compensation follows automatically (gravcomp reads the body's mass), and it is
        refreshed for the current q at once so the very next step is consistent. What is put on
        the flange this way is part of the arm, as the Hand is: it is compensated and never reads
        as external, so it is not the way to carry a load a client declares with SetLoad.
        """
        self._still = 0  # the model changes: the next step is a new one
        self.arms[arm].set_end_effector(mass, com, inertia)
        # The mj_step1 below is the rest of the last step, for the new model; g(q) changes.
        self._unfinished, self._prepared = False, False
        mujoco.mj_setConst(self.model, self.scratch)  # subtree masses etc. from body masses
        mujoco.mj_step1(self.model, self.data)

    # -- what a test does to the world (physics/bodies.py) ----------------------------------------
    def body_state(self, name: str) -> BodyState:
        """A body's pose and velocity now (UnknownBody if there is none of that name)."""
        self.finish_step()  # the velocities of the current state
        return self.bodies.state(name)

    def place_body(self, name: str, position, quaternion=None) -> None:
        """Put a free body at `position`, turned to `quaternion` (None: as it is), at rest;
        from the next step on (NotFree for a link or a fixed body)."""
        self.finish_step()
        self.bodies.place(name, position, quaternion)
        placed = self.bodies.id(name)
        for arm in self._arms:
            if arm.tool is not None:
                arm.tool.body_placed(placed)
        self._still = 0
        self._prepared = False
        mujoco.mj_step1(self.model, self.data)  # what derives from the new state

    def push(self, name: str, force, torque, steps: int) -> None:
        """A wrench (world frame, at the body's centre of mass) on a body during the next
        `steps` steps; replaces a push still acting on it (Immovable: no force moves it)."""
        body = self.bodies.id(name)
        self.bodies.check_push(name, force, torque, steps * self.timestep)  # Immovable too
        self._pushes.push(body, force, torque, steps)
