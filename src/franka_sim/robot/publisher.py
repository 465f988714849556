"""Fills the RobotState from the robot's decisions and the measurement, once per cycle.

Only fields that change are written each cycle (each write costs ~0.3 µs); constant ones
(hand inertials, gravity) once, the status (modes, error bits, success rate) when it changes,
and the measured ones only when the physics measured anew (an arm at rest hands over the same
Measured each cycle, see physics/world.py, "Rest"). Transforms are written through
4×4 views in the wire's column-major order, so no reordered copy is made first; the 2- and
6-number signals (elbow, its rates) are plain floats. The desired-side kinematics (O_T_EE_d
and the Jacobian at q_d) come from the physics thread with the step, because MuJoCo computes
them ~6× faster than numpy would here.
"""

from __future__ import annotations

from dataclasses import dataclass
from operator import attrgetter
from typing import TYPE_CHECKING

import numpy as np

from franka_sim.description import hand
from franka_sim.description.kinematics import elbow as elbow_of
from franka_sim.kernels import impedance_torque, narrow_into
from franka_sim.physics.backend import Measured
from franka_sim.protocol.codec import StateBuffer
from franka_sim.protocol.enums import ControllerMode, MotionGeneratorMode
from franka_sim.protocol.enums import MoveControllerMode as Ctrl
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.robot.settings import RobotSettings
from franka_sim.spatial import column_major, point_twist

if TYPE_CHECKING:
    from franka_sim.robot.external_forces import ExternalForces
    from franka_sim.robot.motion import Motion
    from franka_sim.robot.status import RobotStatus

GRAVITY = np.array([0.0, 0.0, -9.81])
IDLE_MODES = (MotionGeneratorMode.kIdle, ControllerMode.kJointImpedance)
# Fields copied as they are, from a Measured and from ExternalForces (same names in the state).
MEASURED_FIELDS = ("q", "dq", "tau_J", "dtau_J", "theta", "dtheta", "accelerometer_top",
                   "accelerometer_bottom")
_measured_values = attrgetter(*MEASURED_FIELDS)  # a Measured's, as one tuple
EXTERNAL_FIELDS = ("tau_ext_hat_filtered", "O_F_ext_hat_K", "K_F_ext_hat_K", "joint_contact",
                   "cartesian_contact", "joint_collision", "cartesian_collision")


def _zeros(n: int) -> np.ndarray:
    array = np.zeros(n)
    array.setflags(write=False)  # shared: whoever keeps it must never write into it
    return array


ZERO6, ZERO7 = _zeros(6), _zeros(7)


@dataclass(eq=False, slots=True)
class CycleFacts:
    """What one cycle's state reports, as the core decided it: one value, refilled in place
    each cycle (no allocation on the hot path)."""

    status: "RobotStatus"
    external: "ExternalForces"
    message_id: int = 0
    motion: "Motion | None" = None  # the running motion (None: idle)
    success_rate: float = 0.0
    measured: Measured | None = None
    desired_kinematics: tuple | None = None  # (O_T_F_d, J_F_d) at q_d, or None


@dataclass(frozen=True)
class PublishedStart:
    """What the last published state showed of the arm: where a Move's checks start, since
    libfranka's generators start from it."""

    q: np.ndarray  # (7,)
    O_T_EE: np.ndarray  # (16,), column-major as on the wire
    elbow: np.ndarray  # (2,)


class StatePublisher:
    def __init__(self, settings: RobotSettings) -> None:
        self.settings = settings
        self.buffer = s = StateBuffer()
        s.F_T_NE[:] = column_major(hand.F_T_NE_HAND)
        s.m_ee[...] = hand.HAND_MASS
        s.F_x_Cee[:] = hand.HAND_COM
        s.I_ee[:] = column_major(np.asarray(hand.HAND_INERTIA))
        s.O_ddP_O[:] = GRAVITY
        # The transforms as 4×4 (column-major underneath), the accelerometers as (6, 3).
        self._O_T_EE_view = s.matrix("O_T_EE", (4, 4))
        self._O_T_EE_d_view = s.matrix("O_T_EE_d", (4, 4))
        self._O_T_EE_c_view = s.matrix("O_T_EE_c", (4, 4))
        # The fields a step's Measured fills, in MEASURED_FIELDS' order and its arrays' shapes
        # (kernels.narrow_into): the accelerometers as (6, 3).
        self._measured_fields = tuple(
            getattr(s, name).reshape(6, 3) if name.startswith("accelerometer") else getattr(s, name)
            for name in MEASURED_FIELDS)
        self._external_fields = [(name, getattr(s, name)) for name in EXTERNAL_FIELDS]
        self._elbows = s.span("elbow", "elbow_d")  # (elbow, elbow_d): 4 numbers
        self._elbows_c = s.span("elbow_c", "ddelbow_c")  # (elbow_c, delbow_c, ddelbow_c): 6
        # The commanded signals' last values, to difference the next ones against.
        self._O_dP_EE_c: np.ndarray = ZERO6
        self._rates_zero = True  # ddq_d, O_dP_EE_d, O_dP_EE_c, O_ddP_EE_c all hold zeros
        self._elbow_c = (0.0, 0.0)
        self._delbow_c = (0.0, 0.0)
        self._configured: tuple | None = None
        self._idle_written = False
        self._F_T_EE = np.eye(4)
        self._external_version = 0  # ExternalForces.version last written (0: all zero)
        self._written: tuple | None = None  # (Measured, F_T_EE) whose fields the buffer holds
        self._O_T_EE = np.eye(4)
        self._idle_for: Measured | None = None  # the Measured the idle signals were written for
        self._status: tuple | None = None  # (motion, robot_mode) whose modes the buffer holds
        self._flags_version = -1  # RobotStatus.flags_version whose error bits the buffer holds
        self._rate = 0.0  # control_command_success_rate in the buffer

    def pack(self, facts: CycleFacts) -> bytes:
        s, m = self.buffer, facts.measured
        s.message_id[...] = facts.message_id
        F_T_EE = self._configured_frames()
        written = self._written
        if written is None or written[0] is not m or written[1] is not F_T_EE:
            self._written = (m, F_T_EE)
            self._O_T_EE = O_T_EE = np.dot(m.O_T_F, F_T_EE)  # (`@`: the same bits, slower)
            self._O_T_EE_view[...] = O_T_EE
            narrow_into(self._measured_fields, _measured_values(m))
            self._idle_for = None
        O_T_EE = self._O_T_EE

        motion = facts.motion
        if motion is None:
            self._idle_signals(m, O_T_EE)
        else:
            self._motion_signals(motion, m, O_T_EE, F_T_EE, facts.desired_kinematics)
        self._write_status(facts.status, motion, facts.success_rate)
        self._external_forces(facts.external)
        return s.pack()

    def restamp(self, message_id: int) -> bytes:
        """The last packed state again, under another message_id."""
        s = self.buffer
        s.message_id[...] = message_id
        return s.pack()

    def published_start(self) -> PublishedStart:
        """The arm as the last state showed it (fresh arrays, safe to keep)."""
        q = self._written[0].q.copy()
        return PublishedStart(q, column_major(self._O_T_EE).copy(),
                              np.array(elbow_of(q), dtype=float))

    def _write_status(self, status: "RobotStatus", motion: "Motion | None", rate: float) -> None:
        """Modes, error bits and the success rate: rewritten only when they changed."""
        s, robot_mode, written = self.buffer, status.robot_mode, self._status
        if written is None or written[0] is not motion or written[1] is not robot_mode:
            self._status = (motion, robot_mode)
            mg, ctrl = IDLE_MODES if motion is None else motion.spec.state_modes
            s.motion_generator_mode[...] = int(mg)
            s.controller_mode[...] = int(ctrl)
            s.robot_mode[...] = int(robot_mode)
        if status.flags_version != self._flags_version:
            self._flags_version = status.flags_version
            s.errors[:] = status.errors
            s.reflex_reason[:] = status.reflex_reason
        if rate != self._rate:
            self._rate = rate
            s.control_command_success_rate[...] = rate

    def _external_forces(self, external) -> None:
        """The estimate and the contact/collision flags, rewritten only when they changed."""
        if external.version == self._external_version:
            return
        self._external_version = external.version
        for name, field in self._external_fields:
            field[:] = getattr(external, name)

    def _idle_signals(self, m: Measured, O_T_EE: np.ndarray) -> None:
        """Idle: desired and commanded signals follow the measurement; rates are zero."""
        s = self.buffer
        if m is self._idle_for:  # written last cycle, for this very measurement
            return
        if not self._idle_written:  # the zeros need writing once per idle spell
            for field in (s.dq_d, s.ddq_d, s.tau_J_d, s.O_dP_EE_d, s.O_dP_EE_c, s.O_ddP_EE_c):
                field[:] = 0.0
            self._O_dP_EE_c = ZERO6
            self._rates_zero = True
            self._idle_written = True
        s.q_d[:] = m.q
        self._O_T_EE_d_view[...] = O_T_EE
        self._O_T_EE_c_view[...] = O_T_EE
        e0, e1 = elbow_of(m.q)
        elbows = self._elbows
        elbows[0] = elbows[2] = e0
        elbows[1] = elbows[3] = e1
        elbows = self._elbows_c
        elbows[0], elbows[1] = e0, e1
        elbows[2] = elbows[3] = elbows[4] = elbows[5] = 0.0
        self._elbow_c = (e0, e1)
        self._delbow_c = (0.0, 0.0)
        self._idle_for = m

    def _motion_signals(self, motion, m: Measured, O_T_EE, F_T_EE, desired_kinematics):
        """A motion runs: desired signals from its generator, commanded ones from the client."""
        s = self.buffer
        self._idle_written = False
        self._idle_for = None
        spec = motion.spec
        if spec.generator is Gen.kNone:  # torque only: nothing desired but what is measured
            q_d, dq_d, ddq_d = m.q, m.dq, ZERO7
        else:
            ref = motion.reference
            q_d, dq_d, ddq_d = ref.q_d, ref.dq_d, ref.ddq_d
        s.q_d[:] = q_d
        s.dq_d[:] = dq_d
        if spec.torque_controlled or (spec.controller is Ctrl.kCartesianImpedance
                                      and not motion.braking):
            s.tau_J_d[:] = motion.tau_J_d  # the client's, or the Cartesian impedance's
        else:  # the internal impedance's torque, without gravity (as the robot defines tau_J_d):
            settings = self.settings  # K·(q_d − q) + D·(dq_d − dq), D derived from K
            impedance_torque(settings.K_theta, settings.D_theta, q_d, dq_d, m.q, m.dq, s.tau_J_d)
        if desired_kinematics is not None:
            O_T_F_d, J_F_d = desired_kinematics
            O_T_EE_d = np.dot(O_T_F_d, F_T_EE)
            O_dP_EE_d = point_twist(O_T_F_d, J_F_d, F_T_EE, dq_d)
        else:
            O_T_EE_d, O_dP_EE_d = O_T_EE, ZERO6
        self._O_T_EE_d_view[...] = O_T_EE_d
        e0, e1 = elbow_of(m.q)
        d0, d1 = (e0, e1) if q_d is m.q else elbow_of(q_d)
        elbows = self._elbows
        elbows[0], elbows[1], elbows[2], elbows[3] = e0, e1, d0, d1
        O_dP_EE_c, elbow_c = self._commanded_cartesian(motion, O_T_EE_d, O_dP_EE_d, (d0, d1))
        self._write_rates(ddq_d, O_dP_EE_d, O_dP_EE_c)
        self._write_elbow_c(elbow_c)

    def _configured_frames(self) -> np.ndarray:
        """F_T_EE; rewrites the client-configured fields only when a Set* command replaced them."""
        settings, configured = self.settings, self._configured
        if (configured is None or configured[0] is not settings.NE_T_EE
                or configured[1] is not settings.EE_T_K or configured[2] is not settings.load):
            s = self.buffer
            self._configured = (settings.NE_T_EE, settings.EE_T_K, settings.load)
            self._F_T_EE = hand.flange_to_ee(settings.NE_T_EE)
            s.F_T_EE[:] = column_major(self._F_T_EE)
            s.NE_T_EE[:] = column_major(settings.NE_T_EE)
            s.EE_T_K[:] = column_major(settings.EE_T_K)
            s.m_load[...] = settings.load.mass
            s.F_x_Cload[:] = settings.load.F_x_C
            s.I_load[:] = column_major(settings.load.inertia)
        return self._F_T_EE

    def _commanded_cartesian(self, motion, O_T_EE_d, O_dP_EE_d, elbow_d) -> tuple:
        """The c-signals: the client's own Cartesian stream if it drives one, else the d-signals.
        Writes O_T_EE_c; returns (O_dP_EE_c, elbow_c). The stream is the motion's, not the last
        datagram's: on a missed cycle the robot extrapolates it, and libfranka anchors its next
        command on what the state shows (a stale value there is a step in the next command)."""
        generator = motion.spec.generator
        started = motion.last_command is not None
        if started and generator is Gen.kCartesianPosition:
            self._O_T_EE_c_view[...] = motion.cartesian.pose
        else:
            self._O_T_EE_c_view[...] = O_T_EE_d
        if started and generator is Gen.kCartesianVelocity:
            O_dP_EE_c = motion.cartesian.twist.copy()
        else:
            O_dP_EE_c = O_dP_EE_d
        elbow = motion.elbow
        if elbow is not None:
            return O_dP_EE_c, (elbow.position, elbow.flag)
        return O_dP_EE_c, elbow_d

    def _write_rates(self, ddq_d, O_dP_EE_d, O_dP_EE_c) -> None:
        """ddq_d, O_dP_EE_d, and O_dP_EE_c with its rate. A torque-only motion's are all zero
        (the shared zero arrays): written on its first cycle, they stay."""
        previous = self._O_dP_EE_c
        zeros = (ddq_d is ZERO7 and O_dP_EE_d is ZERO6 and O_dP_EE_c is ZERO6
                 and previous is ZERO6)
        if zeros and self._rates_zero:
            return
        s = self.buffer
        s.ddq_d[:] = ddq_d
        s.O_dP_EE_d[:] = O_dP_EE_d
        s.O_ddP_EE_c[:] = (O_dP_EE_c - previous) / DT
        s.O_dP_EE_c[:] = O_dP_EE_c
        self._O_dP_EE_c = O_dP_EE_c  # a fresh array, or a read-only zero: safe to keep
        self._rates_zero = zeros

    def _write_elbow_c(self, elbow_c: tuple[float, float]) -> None:
        """elbow_c and its first two differences, in floats."""
        # One pair at a time: Cython 3.1–3.3 crashes on the nested unpacking (compiled_cycle.py).
        e0, e1 = elbow_c
        p0, p1 = self._elbow_c
        v0, v1 = self._delbow_c
        d0, d1 = (e0 - p0) / DT, (e1 - p1) / DT
        elbows = self._elbows_c
        elbows[0], elbows[1], elbows[2], elbows[3] = e0, e1, d0, d1
        elbows[4], elbows[5] = (d0 - v0) / DT, (d1 - v1) / DT
        self._elbow_c, self._delbow_c = elbow_c, (d0, d1)
