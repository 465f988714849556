"""One arm inside the world: its joints, its drive, its readings, its tool, its queries.

Drive model (physics/drive.py, shared with every engine). Each step applies
tau = tau_ff + K·(q_d − q) + D·(dq_d − dq) + g(q), all evaluated
at the start of the step, as the real drives do with one 1 kHz sample. While a generator runs,
the command also carries its reference acceleration ddq_d, and the drives add the torque that
gives the arm that acceleration, M(q)·ddq_d + c(q, dq) (rotors included): the impedance then
only corrects, and the arm ends a motion on its q_d instead of lagging it by its inertia over
the stiffness (libfranka's generators start the next motion from the measured q). g(q) is the gravity
compensation the robot adds (whole chain and hand), which the world computes for every arm at
once (physics/world.py): at rest it cancels MuJoCo's own bias force to the last bit, so an idle
arm stays exactly where it is, however long it idles. A load declared with SetLoad (the
command's `load`) adds its own gravity on top (physics/declared_load.py). The joints' residual
friction (physics/friction.py) resists every motion; in the motion generators' modes the
drives also add its value at the reference velocity, as the robot's own controller
compensates what it knows, so only torque control feels what is left.

Standstill. An arm that has moved comes back to rest under the idle hold only asymptotically:
float round-off keeps it trembling at ~1e-13 rad/s for ever. So, as a drive's standstill
control does, the hold puts a joint (and a finger at its commanded opening) that is within
SETTLE (physics/drive.py) of its set-point, and slower than SETTLE, exactly there and at
rest: a change below the resolution of a 20-bit joint encoder (6e-6 rad) and four orders of
magnitude below the noise of a measured dq (~1e-2 rad/s), made the same way every run. The band decides how long an arm
settles after a motion (~230 cycles after a 0.5 s joint motion; 1e-9 took ~470), which a
lockstep server runs before it answers the motion's end.

An arm keeps its command until it is given another (`command`); the world's step calls the
other methods, in the order of the step, for every arm.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.kernels import add_feed_forward
from franka_sim.physics.arm_model import FLANGE_SITE, HAND_BODY, write_inertial
from franka_sim.physics.backend import JointCommand, Measured
from franka_sim.physics.declared_load import DeclaredLoad
from franka_sim.physics.drive import SETTLE, DriveLaw
from franka_sim.physics.external_torque import ExternalTorque
from franka_sim.physics.friction import JointFriction
from franka_sim.physics.queries import Queries
from franka_sim.physics.readings import Readings
from franka_sim.physics.scene import ArmPlacement

__all__ = ["Arm"]


class Arm:
    """The arm `placement` describes, in the world's model and data.

    `gravity` is the world's g(q) vector (all dofs; physics/world.py fills it), which the arm's
    drive adds on its own dofs. `queries` computes on the world's `scratch` data.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, scratch: mujoco.MjData,
                 gravity: np.ndarray, placement: ArmPlacement) -> None:
        self.name, self.desc = placement.name, placement.desc
        prefix = placement.prefix
        self.tops = placement.tops
        jids = [model.joint(prefix + j.name).id for j in self.desc.joints]
        qadr, vadr = model.jnt_qposadr[jids], model.jnt_dofadr[jids]
        if not (np.diff(qadr) == 1).all() or not (np.diff(vadr) == 1).all():
            raise RuntimeError("arm joints must be contiguous in qpos/qvel")
        self.qs, self.vs = slice(qadr[0], qadr[0] + 7), slice(vadr[0], vadr[0] + 7)
        flange = model.site(prefix + FLANGE_SITE).id
        self._model, self._data, self._hand = model, data, model.body(prefix + HAND_BODY).id
        # Views into MjData (its buffers never move) and preallocated work arrays.
        self._q, self._dq = data.qpos[self.qs], data.qvel[self.vs]
        self._applied = data.qfrc_applied[self.vs]
        self._gcomp = gravity[self.vs]
        self._dq_prev = np.zeros(7)
        self._ff_accel, self._ff_torque = np.zeros(model.nv), np.zeros(model.nv)
        self._ff_accel_arm, self._ff_torque_arm = self._ff_accel[self.vs], self._ff_torque[self.vs]
        self._bias = data.qfrc_bias[self.vs]
        base = queried = placement.base_frame()
        if placement.rides:  # on the mobile base the root moves: its pose as it is now, in
            root = model.body(prefix + self.desc.root).id  # the data (views) and the scratch
            base = (data.xmat[root].reshape(3, 3), data.xpos[root])
            queried = (scratch.xmat[root].reshape(3, 3), scratch.xpos[root])
        self.friction = JointFriction()
        # The drives (physics/drive.py); the motors' torque limits are the URDF's effort.
        tau_max = np.array([j.limits.effort for j in self.desc.joints], dtype=float)
        self._law = DriveLaw(self._q, self._dq, self._applied, self._gcomp, tau_max,
                             float(model.opt.timestep), self.friction, self._feed_forward)
        self.readings = Readings(model, data, self.desc, prefix, self.qs, self.vs, flange, base,
                                 self.friction.torque)
        self._external = ExternalTorque(model, data, self.vs, jids, self.readings.tau_ext)
        self.declared_load = DeclaredLoad(model, data, scratch, self.vs, flange)
        # The tool on the flange (physics/tool.py), if any: the arm calls its hooks in the order
        # of the world's step and carries its command and reading.
        self.tool = None if placement.tool is None else placement.tool.attach(
            model, data, gravity, prefix, self._hand)
        self.queries = Queries(model, data, scratch, self.qs, self.vs, flange, queried)
        self.cmd: JointCommand | None = None  # what the drives do, until replaced
        self._tool_cmd = None  # a new command for the tool (None: keep its last)
        self._last_cmd: JointCommand | None = None  # the command of the last step taken
        self.prepared_load: object = None  # the load declared_load.gravity is for
        self.last: Measured | None = None  # the readings of the last step (or reset)

    def command(self, cmd: JointCommand, tool: object | None = None) -> None:
        """The drives' command from the next step on; `tool` replaces the tool's (None: keep
        it)."""
        self.cmd, self._tool_cmd = cmd, tool

    def measure(self) -> Measured:
        return self.last

    # -- the world's step, in its order ---------------------------------------------------------
    def same_inputs(self) -> bool:
        """The command is the last step's (physics/drive.py DriveLaw.same_inputs)."""
        return self._law.same_inputs(self._last_cmd, self.cmd, self._tool_cmd, self.tool)

    def settle(self) -> bool:
        """Within SETTLE of the hold: exactly there, at rest (see Standstill above).
        True if a position changed."""
        return self._law.settle(self.cmd, self._tool_cmd, self.tool, SETTLE)

    def drive(self) -> None:
        """The drive torque for this step into qfrc_applied (g(q) prepared at this q)."""
        cmd = self.cmd
        self._law.apply(cmd, self.declared_load.gravity if cmd.load is not None else None)
        if self.tool is not None:
            self.tool.drive(self._tool_cmd)
        self._dq_prev[:] = self._dq

    def _feed_forward(self, ddq_d: np.ndarray) -> None:
        """Add M(q)·ddq_d + c(q, dq): the inverse dynamics of the reference's acceleration, on
        mj_step1's inertia and bias at the current state (c = bias − g; g is already in)."""
        self._ff_accel_arm[:] = ddq_d
        mujoco.mj_mulM(self._model, self._data, self._ff_torque, self._ff_accel)
        add_feed_forward(self._applied, self._ff_torque_arm, self._bias, self._gcomp)

    def after_integration(self) -> None:
        """After mj_step2, before the kinematics move on: ddq, the external torque (on the
        constraint rows the step used) and the tool's own (the Hand's palm for the fingers' new
        positions)."""
        r = self.readings
        np.subtract(self._dq, self._dq_prev, out=r.ddq)
        np.divide(r.ddq, r.timestep7, out=r.ddq)
        self._external.measure()
        if self.tool is not None:
            self.tool.after_integration()

    def record(self) -> None:
        """The step's readings, once the kinematics of the new q are computed (the drive
        torque is still in qfrc_applied)."""
        r, cmd, last = self.readings, self.cmd, self._last_cmd
        r.flange_jacobian()
        if cmd.load is not None:
            carried = last is not None and last.load is cmd.load
            self.declared_load.subtract(r.tau_ext, cmd.load, r.jac, carried)
        self._last_cmd = cmd
        self.last = r.record(None if self.tool is None else self.tool.reading())

    # -- reset (the world's, in its order) --------------------------------------------------------
    def place(self, q0: np.ndarray, tool_setting: object | None = None) -> None:
        """At q0 and at rest in freshly reset data, its tool at its start (or `tool_setting`:
        the Hand's opening); no step to compare with."""
        self._last_cmd = None
        self._law.rest()
        self._q[:] = q0
        if self.tool is not None:
            self.tool.place(tool_setting)

    def hold_still(self) -> None:
        """Gravity compensation alone as the drive (g(q) computed at this q)."""
        self._applied[:] = self._gcomp
        self._law.rest()
        self.friction.rest()
        if self.tool is not None:
            self.tool.hold()

    def record_rest(self) -> None:
        """Rest readings, once the world's forward pass is done."""
        r = self.readings
        r.ddq.fill(0.0)
        r.tau_ext.fill(0.0)
        r.flange_jacobian()
        self.last = r.record(None if self.tool is None else self.tool.reading(), first=True)

    def set_end_effector(self, mass: float, com, inertia) -> None:
        """Write a new rigid body on the flange into the model (the world then refreshes what
        derives from it): mass, CoM in F, inertia about the CoM."""
        inertia = np.asarray(inertia, float).reshape(3, 3)
        if mass < 0 or not np.allclose(inertia, inertia.T):
            raise ValueError("mass must be ≥ 0 and inertia symmetric")
        if self.tool is not None:  # the composite of the tool's parts becomes the given body
            self.tool.set_composite(mass, com, 0.5 * (inertia + inertia.T))
            return
        write_inertial(self._model, self._hand, mass, com, inertia)
