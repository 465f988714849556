"""One arm in a Genesis world: its drive (physics/drive.py's law, as on MuJoCo), its tool, and
the readings of each step assembled into a Measured.

The world (physics/genesis/world.py) moves the state between Genesis and the arm's numpy arrays
once per step: before it, the arm turns its command into joint torques (`drive`); after it, the
arm reads the new state (`record`). g(q) and the feed-forward M(q)·ddq_d + c(q, dq) come from
Genesis's own solver (physics/genesis/dynamics.py).

Readings, as physics/readings.py defines them: tau_J = the drive torque − B·ddq + the joints'
friction, theta = q + tau_J / JOINT_STIFFNESS, their backward differences, O_T_F and J_F of the
hand body (its frame is the flange's) in the arm's base frame. tau_ext is Genesis's constraint
force on the arm's dofs in the robot's sign (contacts; the arm's joint-limit stops are counted
too while a joint is at its limit), plus the pushes on the arm's links, minus a declared load's
gravity (its inertia is not subtracted: the load's acceleration is left in). The accelerometers read
the specific force of gravity alone in each sensor's frame (the arm's own accelerations are
left out).
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.kinematics import fk_frames
from franka_sim.description.urdf import ACCELEROMETER_BOTTOM, ACCELEROMETER_TOP
from franka_sim.physics.backend import JointCommand, Measured
from franka_sim.kernels import add_feed_forward
from franka_sim.physics.drive import SETTLE, DriveLaw
from franka_sim.physics.fingers import (MAX_FINGER_FORCE, OPEN_WIDTH, FingerCommand, Fingers,
                                        FingersMount)
from franka_sim.physics.friction import JointFriction
from franka_sim.physics.readings import JOINT_STIFFNESS
from franka_sim.physics.scene import GRAVITY, ArmPlacement
from franka_sim.spatial import jacobian_in_base, pose_in_base


class GenesisFingers(Fingers):
    """The Hand's fingers on numpy arrays the world keeps in step with Genesis (the drive,
    standstill and reading are physics/fingers.py's). The hand's inertial stays the open
    hand's: Genesis gets no palm rewrite as the fingers move."""

    def __init__(self, q: np.ndarray, v: np.ndarray, applied: np.ndarray,
                 gravity: np.ndarray) -> None:  # noqa: D107 - not Fingers' (no MuJoCo model)
        self._q, self._v, self._applied, self._gravity = q, v, applied, gravity
        self._palm_at = None  # (no palm: after_integration rewrites nothing here)
        self.command = FingerCommand(OPEN_WIDTH, 0.0, MAX_FINGER_FORCE)
        self._drive = (0.0, 0.0)

    def after_integration(self) -> None:
        pass

    def set_composite(self, mass: float, com, inertia) -> None:
        raise NotImplementedError("the Genesis engine keeps the Hand's inertial as described")


class GenesisArm:
    """The arm `placement` describes; `tool_dofs` of its tool (the Hand's fingers: 2)."""

    def __init__(self, placement: ArmPlacement, dynamics, timestep: float, tool_dofs: int) -> None:
        self.name, self.desc, self.placement = placement.name, placement.desc, placement
        self.dynamics = dynamics
        self.timestep = timestep
        n = 7 + tool_dofs
        # The state at the start of the next step (the world writes it after each step), the
        # torque for it, g(q) of every dof (arm, then tool).
        self.q, self.dq, self.applied, self.gravity = (np.zeros(n) for _ in range(4))
        self._q, self._dq, self._applied, self._gcomp = (
            self.q[:7], self.dq[:7], self.applied[:7], self.gravity[:7])
        self.friction = JointFriction()
        tau_max = np.array([j.limits.effort for j in self.desc.joints], dtype=float)
        self._law = DriveLaw(self._q, self._dq, self._applied, self._gcomp, tau_max, timestep,
                             self.friction, self._feed_forward)
        self.tool = None
        if isinstance(placement.tool, FingersMount):
            self.tool = GenesisFingers(self.q[7:], self.dq[7:], self.applied[7:],
                                       self.gravity[7:])
        elif placement.tool is not None:
            raise ValueError("the Genesis engine carries the Franka Hand or no tool")
        self._armature = np.asarray(placement.armature, float)
        self._base = placement.base_frame()
        self._sensors = [[self.desc.frames[name] for name in names if name in self.desc.frames]
                         for names in (ACCELEROMETER_TOP, ACCELEROMETER_BOTTOM)]
        self._g = -np.asarray(GRAVITY)
        self.cmd: JointCommand | None = None
        self._tool_cmd = None
        self._last_cmd: JointCommand | None = None
        self._dq_prev = np.zeros(7)
        self._load_gravity: np.ndarray | None = None  # a declared load's g(q) this step
        self._previous = None  # (tau_J, theta) of the last readings
        self.external = np.zeros(7)  # the environment's torque on the arm over the last step
        self.last: Measured | None = None

    def command(self, cmd: JointCommand, tool: object | None = None) -> None:
        self.cmd, self._tool_cmd = cmd, tool

    def same_inputs(self) -> bool:
        """The command is the last step's (physics/drive.py DriveLaw.same_inputs)."""
        return self._law.same_inputs(self._last_cmd, self.cmd, self._tool_cmd, self.tool)

    # -- the world's step, in its order ---------------------------------------------------------
    def settle(self) -> bool:
        """The idle hold's standstill (physics/arm.py): within SETTLE of the hold, exactly
        there and at rest. True if a position changed (the world writes it to Genesis)."""
        return self._law.settle(self.cmd, self._tool_cmd, self.tool, SETTLE)

    def drive(self) -> None:
        """The torque of every dof for this step into `applied` (the state is current)."""
        self.gravity[:] = self.dynamics.gravity_all(self._q, self.q[7:])
        cmd = self.cmd
        load = cmd.load
        self._load_gravity = None if load is None else self.dynamics.load_gravity(
            self._q, self.q[7:], load.mass, load.F_x_C)
        self._law.apply(cmd, self._load_gravity)
        if self.tool is not None:
            self.tool.drive(self._tool_cmd)
        self._dq_prev[:] = self._dq

    def _feed_forward(self, ddq_d: np.ndarray) -> None:
        """Add M(q)·ddq_d + c(q, dq), Genesis's at the current state (rotors included)."""
        bias, M = self.dynamics.bias_and_mass(self._q, self._dq, self.q[7:])
        add_feed_forward(self._applied, M @ ddq_d, bias, self._gcomp)

    def record(self, constraint: np.ndarray, pushed: np.ndarray | None, flange) -> None:
        """The readings of the step just taken: `constraint` is Genesis's constraint force on
        the arm's dofs, `pushed` the pushes' generalized force on them (None: no push),
        `flange` (O_T_F, J_F) in the world frame at the new q."""
        ddq = (self._dq - self._dq_prev) / self.timestep
        external = self.external
        external[:] = constraint
        if pushed is not None:
            external += pushed
        tau_ext = -external
        if self._load_gravity is not None:  # the declared load's model is the robot's
            tau_ext -= self._load_gravity
        self._last_cmd = self.cmd
        self.last = self._readings(ddq, tau_ext, flange)

    def record_settled(self, flange) -> None:
        """The readings again, once the standstill put the arm exactly on its hold, at rest."""
        self._previous = None if self.last is None else (self.last.tau_J, self.last.theta)
        self.last = self._readings(np.zeros(7), self.last.tau_ext, flange)

    def record_rest(self, flange) -> None:
        self.external.fill(0.0)
        self._previous = None
        self.last = self._readings(np.zeros(7), np.zeros(7), flange)

    def _readings(self, ddq, tau_ext, flange) -> Measured:
        tau_J = self._applied - self._armature * ddq + self.friction.torque
        theta = self._q + tau_J / JOINT_STIFFNESS
        if self._previous is None:
            dtau_J, dtheta = np.zeros(7), np.zeros(7)
        else:
            dtau_J = (tau_J - self._previous[0]) / self.timestep
            dtheta = (theta - self._previous[1]) / self.timestep
        self._previous = (tau_J, theta)
        O_T_F, J_F = flange
        if self._base is not None:
            O_T_F = pose_in_base(O_T_F.copy(), self._base)
            J_F = jacobian_in_base(J_F, self._base)
        top, bottom = self._accelerometers()
        return Measured(
            q=self._q.copy(), dq=self._dq.copy(), ddq=ddq, tau_J=tau_J, dtau_J=dtau_J,
            theta=theta, dtheta=dtheta, O_T_F=O_T_F, accelerometer_top=top,
            accelerometer_bottom=bottom,
            tool=None if self.tool is None else self.tool.reading(), tau_ext=tau_ext, J_F=J_F)

    def _accelerometers(self) -> tuple[np.ndarray, np.ndarray]:
        """Gravity's specific force in each sensor's frame (a sensor not described reads 0)."""
        bodies = [np.eye(4), *fk_frames(self.desc, self._q)]
        out = []
        for frames in self._sensors:
            values = np.zeros((6, 3))
            for i, frame in enumerate(frames[:6]):
                R = (bodies[frame.body] @ frame.offset)[:3, :3]
                values[i] = R.T @ self._g
            out.append(values)
        return out[0], out[1]

    # -- reset ------------------------------------------------------------------------------------
    def place(self, q0, tool_setting: object | None = None) -> None:
        """At q0 and at rest, its tool at its start (or `tool_setting`: the Hand's opening)."""
        self._last_cmd = None
        self._law.rest()
        self.friction.rest()
        self.q[:7] = q0
        self.dq.fill(0.0)
        if self.tool is not None:
            self.tool.place(tool_setting)
        self.gravity[:] = self.dynamics.gravity_all(self._q, self.q[7:])
        self.applied[:] = self.gravity  # gravity compensation alone holds it
