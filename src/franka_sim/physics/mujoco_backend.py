"""The MuJoCo implementation of the physics Backend: one 1 ms step per published state.

Drive model. Each step applies tau = tau_ff + K·(q_d − q) + D·(dq_d − dq) + g(q), all evaluated
at the start of the step, as the real drives do with one 1 kHz sample. g(q) is the gravity
compensation the robot adds (whole chain and hand). It is computed by the same recursive
Newton–Euler pass MuJoCo uses for its own bias force, at zero velocity, so at rest the two
cancel to the last bit: an idle arm stays exactly where it is, however long it idles, which is
what makes runs reproducible from a given pose. A load declared with SetLoad (the command's
`load`) is part of the robot's model, not of the world: its gravity torque J_Cᵀ·(−m·g) is added
on top, so a load that is really carried (a grasped object) holds still, and one that is not
pushes the arm up against the joint impedance, as on the robot. There is no joint friction or
damping: the real robot compensates its own friction in every mode, so a client sees none.

External torque. What the environment does to the arm is exactly MuJoCo's constraint force on
the arm's dofs (contacts of any arm, hand or finger geom — a grasped object's weight reaches the
arm through the finger pads — and any other constraint that acts on it) plus forces applied with
xfrc_applied (a viewer's perturbation, a test's push), minus the arm's own joint-limit stops,
which are the robot's, not the environment's. Finger-joint limits and the finger drive act on
finger dofs only and never reach it. It is reported in the robot's sign (what the robot exerts
on the environment: −that force), with the declared load's gravity and inertia subtracted, as
the robot subtracts its model. Without contact it is exactly zero, at the cost of two checks.

Step structure. `mj_step2` then `mj_step1`: the second half of step n followed by the first
half of step n+1. After it, positions-dependent quantities (flange pose, g(q)) belong to the
new q that we report, while accelerations (ddq, accelerometers) are those of the step just
taken — a sensor reports the acceleration over the interval it sampled. The readings need only
the kinematics of the new q (mj_kinematics, mj_comPos), so `step` computes those and leaves the
rest of mj_step1 (inertia, its factorisation, contacts, velocities, bias) and the next step's
gravity compensation to `finish_step`, which the server calls once the state has left: a
lockstep client waits for none of it. Whoever does not call it gets it done at the start of the
next step. Both orders run the same computations on the same inputs: the results are the same
bits.

Sensors. tau_J is the link-side torque of an elastic joint whose motor carries the rotor
inertia B: tau_J = tau_motor − B·ddq (at rest tau_J = g(q), libfranka's sign). theta models the
joint elasticity with the stiffness K = 7000 Nm/rad inferred from the robot's own θ − q ≈ τ_J/7000
(fr3_facts §2); the elasticity is only reported, not simulated (the joints are rigid here).

Rest. When two consecutive steps changed nothing (state, warm start and inputs bit-identical
before and after, the scene's resting objects asleep), and the next step gets the same command
and finds the data untouched, its result is known exactly: the same state and the same
Measured. It is not recomputed; only the clock advances. An idle arm then costs a comparison
per cycle instead of a step, and every published bit is what stepping would have given.
An arm that has moved comes back to rest under the idle hold only asymptotically: float
round-off keeps it trembling at ~1e-13 rad/s for ever. So, as a drive's standstill control
does, the hold puts a joint (and a finger at its commanded opening) that is within SETTLE of
its set-point, and slower than SETTLE, exactly there and at rest: a change far below any
encoder's resolution, made the same way every run.

Fingers (optional, physics/fingers.py). Two finger joints on the hand, driven each step by the
last FingerCommand with their own gravity load added (so resting fingers rest exactly, and an
idle arm with idle fingers stays bit-exact). Whenever they move, the palm's inertial is rewritten
so that palm + fingers is the end effector the state reports, at every opening.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np

from franka_sim.description import hand
from franka_sim.description.urdf import ACCELEROMETER_BOTTOM, ACCELEROMETER_TOP, ArmDescription
from franka_sim.physics import fingers as fg
from franka_sim.physics.backend import FingerCommand, FingerState, JointCommand, Measured, Payload
from franka_sim.physics.scene import FLANGE_SITE, HAND_BODY, ROTOR_INERTIA_FR3, build_model

JOINT_STIFFNESS = 7000.0  # Nm/rad, inferred (fr3_facts §2, §4)
SETTLE = 1e-9  # rad and rad/s (m and m/s for a finger): the standstill band of the idle hold
_LIMIT_JOINT = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
# What a step reads and writes, except the clock: positions, velocities, warm start, inputs.
_REST_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION) & ~int(mujoco.mjtState.mjSTATE_TIME)
# A step's readings, as one array whose views are the Measured's fields (see _record). The
# 7-vectors sit in rows of 8 so that every field starts 16-byte aligned, as a freshly allocated
# array does: whatever reads them sees the same memory alignment as with separate arrays.
_Q, _DQ, _DDQ, _TAU_J, _THETA, _DTAU_J, _DTHETA, _TAU_EXT = (
    slice(8 * i, 8 * i + 7) for i in range(8))
_TAU_J_THETA, _DTAU_J_DTHETA = slice(24, 39), slice(40, 55)  # each pair with a pad between
_ROWS = 64  # the 7-vectors
_O_T_F, _J_F, _TOP, _BOTTOM = slice(64, 80), slice(80, 122), slice(122, 140), slice(140, 158)
_READINGS = 158
_UNPREPARED = object()  # no g(q) prepared for the next step (see finish_step)


class _FlangeBlock:
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

    @staticmethod
    def size(nv: int) -> int:
        return 16 + 6 * nv


def _clip(f: float, limit: float) -> float:
    return limit if f > limit else (-limit if f < -limit else f)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for 3-vectors (np.cross costs ~10 µs; this ~1)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


class MujocoBackend:
    """Owns one MjModel/MjData pair; not thread-safe (the physics worker serialises access)."""

    def __init__(self, desc: ArmDescription, q0, *, scene_xml: str | os.PathLike | None = None,
                 armature=ROTOR_INERTIA_FR3, fingers: bool = False) -> None:
        self.desc = desc
        self.model = model = build_model(desc, armature=armature, scene_xml=scene_xml,
                                         fingers=fingers)
        self.timestep = float(model.opt.timestep)
        self.data = data = mujoco.MjData(model)
        self._scratch = mujoco.MjData(model)  # for queries, so they never disturb the state

        jids = [model.joint(j.name).id for j in desc.joints]
        qadr, vadr = model.jnt_qposadr[jids], model.jnt_dofadr[jids]
        if not (np.diff(qadr) == 1).all() or not (np.diff(vadr) == 1).all():
            raise RuntimeError("arm joints must be contiguous in qpos/qvel")
        self._qs, self._vs = slice(qadr[0], qadr[0] + 7), slice(vadr[0], vadr[0] + 7)
        self._flange = model.site(FLANGE_SITE).id
        self._flange_body = int(model.site_bodyid[self._flange])
        self._arm_joint = np.zeros(model.njnt, dtype=bool)  # the arm's joints, by joint id
        self._arm_joint[jids] = True
        self._hand = model.body(HAND_BODY).id
        self._armature = model.dof_armature[self._vs].copy()

        # Views into MjData (its buffers never move) and preallocated work arrays.
        self._q, self._dq = data.qpos[self._qs], data.qvel[self._vs]
        self._qpos, self._sensordata = data.qpos, data.sensordata
        self._scratch_qpos, self._scratch_qvel = self._scratch.qpos, self._scratch.qvel
        self._scratch_flange_mat = self._scratch.site_xmat[self._flange]
        self._scratch_flange_pos = self._scratch.site_xpos[self._flange]
        self._applied = data.qfrc_applied[self._vs]
        self._rne = np.zeros(model.nv)
        self._gcomp = self._rne[self._vs]  # g(q) of the arm (see _gravity_at_rest)
        self._flange_pos = data.site_xpos[self._flange]
        self._flange_mat = data.site_xmat[self._flange]
        self._tmp = np.zeros(7)
        self._dq_prev = np.zeros(7)
        self._ff_accel, self._ff_torque = np.zeros(model.nv), np.zeros(model.nv)
        # Divisors as arrays: a ufunc converts a Python scalar operand on every call.
        self._timesteps = np.full(15, self.timestep)  # for dtau_J and dtheta (with their pad)
        self._timestep7 = self._timesteps[:7]
        self._stiffness = np.full(7, JOINT_STIFFNESS)
        self._last: Measured | None = None
        self._init_readings()
        # External torque (views and buffers).
        self._constraint = data.qfrc_constraint[self._vs]
        self._xfrc = data.xfrc_applied
        self._generalized = np.zeros(model.nv)
        self._gravity_vector = model.opt.gravity.copy()
        self._load_gravity = np.zeros(7)  # the declared load's g(q), added this step
        self._zero3 = np.zeros(3)
        self._load_velocity: tuple[Payload, np.ndarray] | None = None  # (load, [v_C; ω]) last step
        # Rest detection: the data as a step found and left it (see the module docstring).
        size = mujoco.mj_stateSize(model, _REST_STATE)
        self._before, self._after, self._now = np.empty(size), np.empty(size), np.empty(size)
        self._asleep = data.tree_asleep.copy()
        self._last_cmd: JointCommand | None = None
        self._still = 0  # consecutive steps that changed nothing
        self._unfinished = False  # the last step's mj_step1 is still to do (finish_step)
        self._prepared_for: object = _UNPREPARED  # the load (or None) g(q) is prepared with
        self.has_fingers = fingers
        if fingers:
            self._init_fingers()
        self.reset(q0)

    def _init_readings(self) -> None:
        """The work arrays the readings (and the desired-state kinematics) are assembled in.

        A step's holds the 7-vectors as they are published (computed in place), then what the
        gather picks the other fields from: the flange block and the sensor data. Measured's
        arrays are then one allocation and one indexing per step, not one per field.
        """
        m, nv, dof = self.model, self.model.nv, self._vs.start
        sensors = _ROWS + _FlangeBlock.size(nv)
        self._work = work = np.zeros(sensors + m.nsensordata)
        self._readings_flange = flange = _FlangeBlock(work, _ROWS, nv, dof)
        self._jac = flange.jac
        self._work_sensors = work[sensors:]
        # Accelerometers: (top, bottom) × joints 1..6 × xyz; a sensor the description lacks
        # reads a 0 of O_T_F's last row.
        acc = np.full((2, 6, 3), flange.last_row)
        for k, names in enumerate((ACCELEROMETER_TOP, ACCELEROMETER_BOTTOM)):
            for i, name in enumerate(names):
                if name in self.desc.frames:
                    acc[k, i] = sensors + m.sensor_adr[m.sensor(name).id] + np.arange(3)
        self._gather = np.concatenate([np.arange(_ROWS), flange.index, acc.ravel()])
        assert self._gather.size == _READINGS
        self._query_work = np.zeros(_FlangeBlock.size(nv))
        self._query_flange = _FlangeBlock(self._query_work, 0, nv, dof)
        self._work_q, self._work_dq = work[_Q], work[_DQ]
        self._ddq, self._tau_J, self._theta = work[_DDQ], work[_TAU_J], work[_THETA]
        self._tau_J_theta, self._derivatives = work[_TAU_J_THETA], work[_DTAU_J_DTHETA]
        self._tau_ext = work[_TAU_EXT]
        self._previous = np.zeros(15)  # the last step's tau_J and theta (views of its readings)

    def _init_fingers(self) -> None:
        m, d = self.model, self.data
        jids = [m.joint(name).id for name in fg.FINGER_JOINTS]
        qadr, vadr = [int(a) for a in m.jnt_qposadr[jids]], [int(a) for a in m.jnt_dofadr[jids]]
        if qadr[1] != qadr[0] + 1 or vadr[1] != vadr[0] + 1:
            raise RuntimeError("finger joints must be contiguous in qpos/qvel")
        fq, fv = slice(qadr[0], qadr[0] + 2), slice(vadr[0], vadr[0] + 2)
        self._finger_q, self._finger_v = d.qpos[fq], d.qvel[fv]
        self._finger_applied, self._finger_gravity = d.qfrc_applied[fv], self._rne[fv]
        self._palm = fg.Palm(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)
        self._palm_at: list[float] | None = None  # finger positions the palm is for
        self._finger_cmd = FingerCommand(fg.OPEN_WIDTH, 0.0, fg.MAX_FINGER_FORCE)
        self._finger_drive = (0.0, 0.0)

    # -- the hot path ---------------------------------------------------------------------------
    def step(self, cmd: JointCommand, fingers: FingerCommand | None = None) -> Measured:
        self.finish_step()
        same = self._same_inputs(cmd, fingers)
        if same and self._still >= 2 and self._untouched():
            self.data.time += self.timestep  # the step mj_step would take, to the bit
            return self._last
        if same:
            mujoco.mj_getState(self.model, self.data, self._before, _REST_STATE)
            self._asleep[:] = self.data.tree_asleep
        measured = self._step(cmd, fingers)
        self._last_cmd = cmd
        if same:  # rest detection compares whole steps (an idle hold: no client waits)
            self.finish_step()
            mujoco.mj_getState(self.model, self.data, self._after, _REST_STATE)
            still = (np.array_equal(self._before, self._after)
                     and np.array_equal(self._asleep, self.data.tree_asleep))
            self._still = self._still + 1 if still else 0
        else:
            self._still = 0
        return measured

    def finish_step(self) -> None:
        """The rest of the last step: mj_step1 beyond the kinematics, and g(q) at the new q
        (for the load the last command declared: the next one almost always declares it too)."""
        if not self._unfinished:
            return
        self._unfinished = False
        mujoco.mj_step1(self.model, self.data)
        self._prepare_gravity(self._last_cmd.load)

    def _prepare_gravity(self, load: Payload | None) -> None:
        """g(q) at the current q: the arm's into self._rne, the declared load's (on the same
        scratch kinematics) into self._load_gravity."""
        self._gravity_at_rest()
        if load is not None:
            self._declared_load_gravity(load)
        self._prepared_for = load

    def _same_inputs(self, cmd: JointCommand, fingers: FingerCommand | None) -> bool:
        """The command is the last step's (the same arrays: the core replaces, never mutates)."""
        last = self._last_cmd
        if last is None or not (fingers is None or fingers == self._finger_cmd):
            return False
        return cmd is last or (
            cmd.tau_ff is last.tau_ff and cmd.q_d is last.q_d and cmd.dq_d is last.dq_d
            and cmd.K is last.K and cmd.D is last.D and cmd.load is last.load
            and cmd.ddq_d is last.ddq_d)

    def _untouched(self) -> bool:
        """Nothing wrote into the data since the last step (a test's push, a reset)."""
        mujoco.mj_getState(self.model, self.data, self._now, _REST_STATE)
        return bool(np.array_equal(self._now, self._after)
                    and np.array_equal(self._asleep, self.data.tree_asleep))

    def _step(self, cmd: JointCommand, fingers: FingerCommand | None) -> Measured:
        m, d, tmp, applied = self.model, self.data, self._tmp, self._applied
        load = cmd.load
        if cmd.hold and self._standstill(cmd.q_d, fingers):
            self._prepared_for = _UNPREPARED  # q moved: g(q) is recomputed (mj_step1 is not)
        if self._prepared_for is not load:
            self._prepare_gravity(load)
        self._prepared_for = _UNPREPARED
        np.subtract(cmd.q_d, self._q, out=tmp)
        np.multiply(cmd.K, tmp, out=applied)
        np.subtract(cmd.dq_d, self._dq, out=tmp)
        tmp *= cmd.D
        applied += tmp
        applied += cmd.tau_ff
        applied += self._gcomp
        if cmd.ddq_d is not None:
            self._feed_forward(cmd.ddq_d)
        if load is not None:
            applied += self._load_gravity
        if self.has_fingers:
            self._drive_fingers(fingers)
        self._dq_prev[:] = self._dq
        mujoco.mj_step2(m, d)
        np.subtract(self._dq, self._dq_prev, out=self._ddq)
        np.divide(self._ddq, self._timestep7, out=self._ddq)
        tau_ext = self._external_torque()  # before step1 rebuilds the constraint rows
        if self.has_fingers:
            self._update_palm()
        mujoco.mj_kinematics(m, d)  # what the readings need of mj_step1 (see finish_step)
        mujoco.mj_comPos(m, d)
        self._unfinished = True
        self._flange_jacobian()
        if load is not None:
            tau_ext -= self._load_gravity
            tau_ext -= self._declared_load_inertia(load, self._jac[:, self._vs].copy())
        else:
            self._load_velocity = None
        return self._record(first=False)  # the drive torque is still in qfrc_applied

    def _feed_forward(self, ddq_d: np.ndarray) -> None:
        """Add M(q)·ddq_d + c(q, dq) to the drive torque: the inverse dynamics of the reference's
        acceleration (rotors included), on mj_step1's inertia and bias at the current state."""
        m, d, accel, out = self.model, self.data, self._ff_accel, self._ff_torque
        accel[self._vs] = ddq_d
        mujoco.mj_mulM(m, d, out, accel)
        applied = self._applied
        applied += out[self._vs]
        applied += d.qfrc_bias[self._vs]
        applied -= self._gcomp  # c(q, dq) = bias − g(q); g is already in

    def _standstill(self, q_d: np.ndarray, fingers: FingerCommand | None) -> bool:
        """Within SETTLE of the hold: exactly there, at rest (see Rest in the module docstring).
        True if a position changed."""
        tmp, q, dq = self._tmp, self._q, self._dq
        moved = False
        if (np.abs(dq, out=tmp).max() < SETTLE
                and np.abs(np.subtract(q, q_d, out=tmp), out=tmp).max() < SETTLE):
            moved = not np.array_equal(q, q_d)
            q[:] = q_d
            dq[:] = 0.0
        if not self.has_fingers:
            return moved
        c = fingers or self._finger_cmd
        if c.speed != 0.0:
            return moved
        target, fq, fv = 0.5 * c.width, self._finger_q, self._finger_v
        for i, (x, v) in enumerate(zip(fq.tolist(), fv.tolist())):
            if abs(x - target) < SETTLE and abs(v) < SETTLE:
                moved = moved or x != target
                fq[i], fv[i] = target, 0.0
        return moved

    def _external_torque(self) -> np.ndarray:
        """(7,) torque the robot exerts on its environment over the step just integrated.

        Called between mj_step2 and mj_step1, while the constraint rows (efc_*) and the
        kinematics are still those the step used. Written into the readings' work array.
        """
        external = self._tau_ext
        touched, pushed = np.count_nonzero(self._constraint), np.count_nonzero(self._xfrc)
        if touched:
            external[:] = self._constraint
        else:
            external.fill(0.0)
            if not pushed:
                return external
        m, d, gen = self.model, self.data, self._generalized
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

    def _flange_jacobian(self) -> None:
        """The flange Jacobian at the current q into the readings (kinematics must be fresh)."""
        block = self._readings_flange
        mujoco.mj_jacSite(self.model, self.data, block.jacp, block.jacr, self._flange)

    def _declared_load_gravity(self, load: Payload) -> None:
        """g(q) of the declared load into self._load_gravity, on the scratch kinematics at q."""
        s, f, gen = self._scratch, self._flange, self._generalized
        point = s.site_xpos[f] + s.site_xmat[f].reshape(3, 3) @ load.F_x_C
        gen[:] = 0.0
        mujoco.mj_applyFT(self.model, s, -load.mass * self._gravity_vector, self._zero3, point,
                          self._flange_body, gen)  # Jᵀ·(the force that holds it up)
        self._load_gravity[:] = gen[self._vs]

    def _declared_load_inertia(self, load: Payload, J_F: np.ndarray) -> np.ndarray:
        """(7,) torque that accelerates the declared load over the step just taken.

        Its CoM velocity and angular velocity are differenced across steps, which is exactly the
        mean acceleration over the step (the interval ddq and the constraint force refer to).
        """
        R = self._flange_mat.reshape(3, 3)
        r = R @ load.F_x_C
        twist = J_F @ self._dq  # flange [v; ω]
        omega = twist[3:]
        twist[:3] += _cross(omega, r)  # the CoM's velocity
        previous, self._load_velocity = self._load_velocity, (load, twist)
        if previous is None or previous[0] is not load:
            return np.zeros(7)
        acceleration = (twist - previous[1]) / self.timestep
        I_world = R @ load.inertia @ R.T
        torque = I_world @ acceleration[3:] + _cross(omega, I_world @ omega)
        gen = self._generalized
        gen[:] = 0.0
        mujoco.mj_applyFT(self.model, self.data, load.mass * acceleration[:3], torque,
                          self._flange_pos + r, self._flange_body, gen)
        return gen[self._vs]

    def _drive_fingers(self, command: FingerCommand | None) -> None:
        """Finger forces for this step: a force-limited PD on each finger plus its gravity load."""
        if command is not None:
            self._finger_cmd = command
        c = self._finger_cmd
        target, velocity = 0.5 * c.width, 0.5 * c.speed
        limit = max(0.0, min(c.force, fg.MAX_FINGER_FORCE))
        (x1, x2), (v1, v2) = self._finger_q.tolist(), self._finger_v.tolist()
        f1 = _clip(fg.FINGER_KP * (target - x1) + fg.FINGER_KD * (velocity - v1), limit)
        f2 = _clip(fg.FINGER_KP * (target - x2) + fg.FINGER_KD * (velocity - v2), limit)
        g1, g2 = self._finger_gravity.tolist()
        self._finger_applied[0], self._finger_applied[1] = f1 + g1, f2 + g2
        self._finger_drive = (f1, f2)

    def _update_palm(self) -> None:
        """Rewrite the palm for the fingers' new positions, so the hand stays the reported body."""
        x = self._finger_q.tolist()
        if x != self._palm_at:
            self._palm.write(self.model, self._hand, *x)
            self._palm_at = x

    def _finger_state(self) -> FingerState | None:
        if not self.has_fingers:
            return None
        (x1, x2), (v1, v2) = self._finger_q.tolist(), self._finger_v.tolist()
        f1, f2 = self._finger_drive
        return FingerState(width=x1 + x2, speed=v1 + v2, force=-0.5 * (f1 + f2))

    def _gravity_at_rest(self) -> None:
        """g(q) at the current q into self._rne (self._gcomp: the arm's part), bit-identical to
        MuJoCo's bias at dq = 0.

        All four passes are needed: the queries leave the scratch at other positions and
        velocities, and even at dq = 0 mj_comVel's zeros carry signs that depend on q.
        """
        m, s = self.model, self._scratch
        self._scratch_qpos[:] = self._qpos
        self._scratch_qvel.fill(0.0)
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)
        mujoco.mj_comVel(m, s)
        mujoco.mj_rne(m, s, 0, self._rne)

    def _record(self, *, first: bool) -> Measured:
        """The readings of the step just taken, as one fresh array the Measured's fields view.

        The drive torque is in qfrc_applied, ddq, tau_ext and the Jacobian in the work array.
        """
        tau_J, theta = self._tau_J, self._theta
        np.multiply(self._armature, self._ddq, out=tau_J)
        np.subtract(self._applied, tau_J, out=tau_J)
        np.divide(tau_J, self._stiffness, out=theta)
        theta += self._q
        if first:
            self._derivatives.fill(0.0)
        else:  # dtau_J and dtheta in one go (the pad between them stays 0)
            np.subtract(self._tau_J_theta, self._previous, out=self._derivatives)
            np.divide(self._derivatives, self._timesteps, out=self._derivatives)
        self._work_q[:] = self._q
        self._work_dq[:] = self._dq
        self._readings_flange.mat[:] = self._flange_mat
        self._readings_flange.pos[:] = self._flange_pos
        self._work_sensors[:] = self._sensordata
        r = self._work[self._gather]
        self._previous = r[_TAU_J_THETA]
        self._last = Measured(
            q=r[_Q], dq=r[_DQ], ddq=r[_DDQ], tau_J=r[_TAU_J], dtau_J=r[_DTAU_J], theta=r[_THETA],
            dtheta=r[_DTHETA], O_T_F=r[_O_T_F].reshape(4, 4),
            accelerometer_top=r[_TOP].reshape(6, 3), accelerometer_bottom=r[_BOTTOM].reshape(6, 3),
            fingers=self._finger_state(), tau_ext=r[_TAU_EXT], J_F=r[_J_F].reshape(6, 7))
        return self._last

    def measure(self) -> Measured:
        return self._last

    def reset(self, q0) -> None:
        """At rest at q0: gravity compensation alone holds the arm, so sensors read rest values."""
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (7,):
            raise ValueError(f"q0 must have shape (7,), got {q0.shape}")
        m, d = self.model, self.data
        self._still, self._last_cmd = 0, None
        self._unfinished, self._prepared_for = False, _UNPREPARED  # all is recomputed below
        mujoco.mj_resetData(m, d)
        self._q[:] = q0
        if self.has_fingers:  # open, at rest, the palm matching
            self._finger_q[:] = 0.5 * fg.OPEN_WIDTH
            self._finger_cmd = FingerCommand(fg.OPEN_WIDTH, 0.0, fg.MAX_FINGER_FORCE)
            self._finger_drive = (0.0, 0.0)
            self._palm_at = None
            self._update_palm()
        self._gravity_at_rest()
        self._applied[:] = self._gcomp
        if self.has_fingers:
            self._finger_applied[:] = self._finger_gravity
        mujoco.mj_forward(m, d)  # qacc = 0 here: gravity compensation alone holds the arm
        self._load_velocity = None
        self._ddq.fill(0.0)
        self._tau_ext.fill(0.0)
        self._flange_jacobian()
        self._record(first=True)

    # -- queries (scratch data, state untouched) --------------------------------------------------
    def _at(self, q, dq=None) -> mujoco.MjData:
        s = self._scratch
        s.qpos[:] = self.data.qpos  # scene objects where they are
        s.qvel[:] = 0.0
        s.qpos[self._qs] = q
        if dq is not None:
            s.qvel[self._vs] = dq
        mujoco.mj_fwdPosition(self.model, s)
        mujoco.mj_fwdVelocity(self.model, s)
        return s

    def gravity(self, q) -> np.ndarray:
        return self._at(q).qfrc_bias[self._vs].copy()

    def coriolis(self, q, dq) -> np.ndarray:
        bias = self._at(q, dq).qfrc_bias[self._vs].copy()  # copy: gravity() reuses the scratch
        return bias - self.gravity(q)

    def mass_matrix(self, q, *, include_armature: bool = False) -> np.ndarray:
        s = self._at(q)
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, s, full)
        M = full[self._vs, self._vs].copy()
        if not include_armature:
            M[np.diag_indices(7)] -= self.model.dof_armature[self._vs]
        return M

    def jacobian_flange(self, q) -> np.ndarray:
        s = self._at(q)
        jacp, jacr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        mujoco.mj_jacSite(self.model, s, jacp, jacr, self._flange)
        return np.vstack([jacp[:, self._vs], jacr[:, self._vs]])

    def flange_pose(self, q) -> np.ndarray:
        """O_T_F at q computed by MuJoCo (for cross-checks against the numpy kinematics)."""
        s = self._at(q)
        pose = np.eye(4)
        pose[:3, :3] = s.site_xmat[self._flange].reshape(3, 3)
        pose[:3, 3] = s.site_xpos[self._flange]
        return pose

    def flange_pose_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """O_T_F and the flange Jacobian at q from one kinematics pass (the desired-state path)."""
        m, s, block = self.model, self._scratch, self._query_flange
        self._scratch_qpos[:] = self._qpos
        self._scratch_qpos[self._qs] = q
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)  # what mj_jacSite needs, nothing more
        mujoco.mj_jacSite(m, s, block.jacp, block.jacr, self._flange)
        block.mat[:] = self._scratch_flange_mat
        block.pos[:] = self._scratch_flange_pos
        r = self._query_work[block.index]
        return r[:16].reshape(4, 4), r[16:].reshape(6, 7)

    # -- run-time changes -------------------------------------------------------------------------
    def set_end_effector(self, mass: float, com, inertia) -> None:
        """Replace the rigid body on the flange (Hand + load): mass, CoM in F, inertia about CoM.

        Gravity compensation follows automatically (gravcomp reads the body's mass), and it is
        refreshed for the current q at once so the very next step is consistent. What is put on
        the flange this way is part of the arm, as the Hand is: it is compensated and never reads
        as external, so it is not the way to carry a load a client declares with SetLoad.
        """
        inertia = np.asarray(inertia, float).reshape(3, 3)
        self._still = 0  # the model changes: the next step is a new one
        if mass < 0 or not np.allclose(inertia, inertia.T):
            raise ValueError("mass must be ≥ 0 and inertia symmetric")
        # The mj_step1 below is the rest of the last step, for the new model; g(q) changes.
        self._unfinished, self._prepared_for = False, _UNPREPARED
        if self.has_fingers:  # the composite of palm + fingers becomes the given body
            self._palm.set_composite(mass, com, 0.5 * (inertia + inertia.T))
            self._palm_at = None
            self._update_palm()
            mujoco.mj_setConst(self.model, self._scratch)
            mujoco.mj_step1(self.model, self.data)
            return
        principal, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
        if np.linalg.det(axes) < 0:
            axes[:, 0] = -axes[:, 0]
        m, b = self.model, self._hand
        m.body_mass[b] = mass
        m.body_ipos[b] = np.asarray(com, float)
        m.body_inertia[b] = np.clip(principal, 0.0, None)
        mujoco.mju_mat2Quat(m.body_iquat[b], np.ascontiguousarray(axes).ravel())
        mujoco.mj_setConst(m, self._scratch)  # subtree masses etc. derived from body masses
        mujoco.mj_step1(m, self.data)  # recompute g(q) at the current state
