"""Fills the RobotState from the robot's decisions and the measurement, once per cycle.

Only fields that change are written each cycle (each write costs ~0.3 µs); constant ones
(hand inertials, gravity) once, and the measured ones only when the physics measured anew (an
arm at rest hands over the same Measured each cycle, see physics/mujoco_backend.py § Rest). The desired-side kinematics (O_T_EE_d and the Jacobian at q_d)
come from the physics thread with the step, because MuJoCo computes them ~6× faster than
numpy would here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from franka_sim.description import hand
from franka_sim.physics.backend import Measured
from franka_sim.protocol.codec import StateBuffer
from franka_sim.protocol.enums import MoveMotionGeneratorMode
from franka_sim.robot.controllers import impedance_torque
from franka_sim.description.kinematics import elbow as elbow_of
from franka_sim.robot.frames import column_major
from franka_sim.robot.settings import RobotSettings

if TYPE_CHECKING:
    from franka_sim.robot.core import RobotCore

GRAVITY = np.array([0.0, 0.0, -9.81])
DT = 1e-3


def ee_twist(O_T_F: np.ndarray, J_F: np.ndarray, F_T_EE: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """Twist of the EE point in the base frame from the flange Jacobian."""
    twist = J_F @ dq
    r = O_T_F[:3, :3] @ F_T_EE[:3, 3]
    w = twist[3:]  # ω × r, written out: np.cross costs ~15 µs on 3-vectors
    twist[0] += w[1] * r[2] - w[2] * r[1]
    twist[1] += w[2] * r[0] - w[0] * r[2]
    twist[2] += w[0] * r[1] - w[1] * r[0]
    return twist


class StatePublisher:
    def __init__(self, settings: RobotSettings) -> None:
        self.settings = settings
        self.buffer = s = StateBuffer()
        s.F_T_NE[:] = column_major(hand.F_T_NE_HAND)
        s.m_ee[...] = hand.HAND_MASS
        s.F_x_Cee[:] = hand.HAND_COM
        s.I_ee[:] = column_major(np.asarray(hand.HAND_INERTIA))
        s.O_ddP_O[:] = GRAVITY
        self._O_dP_EE_c = np.zeros(6)
        self._elbow_c = np.zeros(2)
        self._delbow_c = np.zeros(2)
        self._configured: tuple | None = None
        self._idle_written = False
        self._F_T_EE = np.eye(4)
        self._external_version = 0  # ExternalForces.version last written (0: all zero)
        self._written: tuple | None = None  # (Measured, F_T_EE) whose fields the buffer holds
        self._O_T_EE = np.eye(4)
        self._idle_for: Measured | None = None  # the Measured the idle signals were written for

    def pack(self, core: "RobotCore", m: Measured, desired_kinematics) -> bytes:
        s, settings = self.buffer, self.settings
        s.message_id[...] = core.message_id
        F_T_EE = self._configured_frames()
        written = self._written
        if written is None or written[0] is not m or written[1] is not F_T_EE:
            self._written = (m, F_T_EE)
            self._O_T_EE = O_T_EE = m.O_T_F @ F_T_EE
            s.O_T_EE[:] = column_major(O_T_EE)
            s.q[:] = m.q
            s.dq[:] = m.dq
            s.tau_J[:] = m.tau_J
            s.dtau_J[:] = m.dtau_J
            s.theta[:] = m.theta
            s.dtheta[:] = m.dtheta
            s.accelerometer_top[:] = m.accelerometer_top.ravel()
            s.accelerometer_bottom[:] = m.accelerometer_bottom.ravel()
            self._idle_for = None
        O_T_EE = self._O_T_EE

        motion = core.motion if core.motion_running else None
        if motion is None:
            self._idle_signals(m, O_T_EE)
        else:
            self._motion_signals(core, motion, m, O_T_EE, F_T_EE, desired_kinematics)
        mg, ctrl = core.state_modes
        s.motion_generator_mode[...] = int(mg)
        s.controller_mode[...] = int(ctrl)
        s.robot_mode[...] = int(core.robot_mode)
        s.errors[:] = core.errors
        s.reflex_reason[:] = core.reflex_reason
        s.control_command_success_rate[...] = core.success_rate
        self._external_forces(core.external)
        return s.pack()

    def _external_forces(self, external) -> None:
        """The estimate and the contact/collision flags, rewritten only when they changed."""
        if external.version == self._external_version:
            return
        self._external_version = external.version
        s = self.buffer
        s.tau_ext_hat_filtered[:] = external.tau_ext_hat_filtered
        s.O_F_ext_hat_K[:] = external.O_F_ext_hat_K
        s.K_F_ext_hat_K[:] = external.K_F_ext_hat_K
        s.joint_contact[:] = external.joint_contact
        s.cartesian_contact[:] = external.cartesian_contact
        s.joint_collision[:] = external.joint_collision
        s.cartesian_collision[:] = external.cartesian_collision

    def _idle_signals(self, m: Measured, O_T_EE: np.ndarray) -> None:
        """Idle: desired and commanded signals follow the measurement; rates are zero."""
        s = self.buffer
        if m is self._idle_for:  # written last cycle, for this very measurement
            return
        if not self._idle_written:  # the zeros need writing once per idle spell
            for field in (s.dq_d, s.ddq_d, s.tau_J_d, s.O_dP_EE_d, s.O_dP_EE_c, s.O_ddP_EE_c,
                          s.delbow_c, s.ddelbow_c):
                field[:] = 0.0
            self._O_dP_EE_c[:] = 0.0
            self._idle_written = True
        s.q_d[:] = m.q
        pose = column_major(O_T_EE)
        s.O_T_EE_d[:] = pose
        s.O_T_EE_c[:] = pose
        elbow = elbow_of(m.q)
        s.elbow[:] = elbow
        s.elbow_d[:] = elbow
        s.elbow_c[:] = elbow
        self._elbow_c[:] = elbow
        self._delbow_c[:] = 0.0
        self._idle_for = m

    def _motion_signals(self, core, motion, m: Measured, O_T_EE, F_T_EE, desired_kinematics):
        """A motion runs: desired signals from its generator, commanded ones from the client."""
        s, settings = self.buffer, self.settings
        self._idle_written = False
        self._idle_for = None
        q_d = core.desired_q
        if q_d is None:  # torque only: nothing desired but what is measured
            q_d, dq_d, ddq_d = m.q, m.dq, np.zeros(7)
        else:
            ref = motion.reference
            dq_d, ddq_d = ref.dq_d, ref.ddq_d
        s.q_d[:] = q_d
        s.dq_d[:] = dq_d
        s.ddq_d[:] = ddq_d
        if motion.spec.torque_controlled:
            s.tau_J_d[:] = motion.tau_J_d
        else:  # the internal impedance's torque, without gravity (as the robot defines tau_J_d)
            s.tau_J_d[:] = impedance_torque(settings.K_theta, q_d, dq_d, m.q, m.dq)
        if desired_kinematics is not None:
            O_T_F_d, J_F_d = desired_kinematics
            O_T_EE_d = O_T_F_d @ F_T_EE
            O_dP_EE_d = ee_twist(O_T_F_d, J_F_d, F_T_EE, dq_d)
        else:
            O_T_EE_d, O_dP_EE_d = O_T_EE, np.zeros(6)
        s.O_T_EE_d[:] = column_major(O_T_EE_d)
        s.O_dP_EE_d[:] = O_dP_EE_d
        self._commanded_cartesian(motion, O_T_EE_d, O_dP_EE_d, q_d)
        s.elbow[:] = elbow_of(m.q)
        s.elbow_d[:] = elbow_of(q_d)

    def _configured_frames(self) -> np.ndarray:
        """F_T_EE; rewrites the client-configured fields only when a Set* command replaced them."""
        settings, s = self.settings, self.buffer
        key = (settings.NE_T_EE, settings.EE_T_K, settings.load)
        if self._configured is None or any(a is not b for a, b in zip(key, self._configured)):
            self._configured = key
            self._F_T_EE = hand.F_T_NE_HAND @ settings.NE_T_EE
            s.F_T_EE[:] = column_major(self._F_T_EE)
            s.NE_T_EE[:] = column_major(settings.NE_T_EE)
            s.EE_T_K[:] = column_major(settings.EE_T_K)
            s.m_load[...] = settings.load.mass
            s.F_x_Cload[:] = settings.load.F_x_C
            s.I_load[:] = column_major(settings.load.inertia)
        return self._F_T_EE

    def _commanded_cartesian(self, motion, O_T_EE_d, O_dP_EE_d, q_d) -> None:
        """The c-signals: the client's own Cartesian stream if it drives one, else the d-signals."""
        s = self.buffer
        command = motion.last_command
        generator = motion.spec.generator
        if command is not None and generator is MoveMotionGeneratorMode.kCartesianPosition:
            s.O_T_EE_c[:] = command["O_T_EE_c"]
        else:
            s.O_T_EE_c[:] = column_major(O_T_EE_d)
        if command is not None and generator is MoveMotionGeneratorMode.kCartesianVelocity:
            dP = np.asarray(command["O_dP_EE_c"], dtype=float)
        else:
            dP = O_dP_EE_d
        s.O_ddP_EE_c[:] = (dP - self._O_dP_EE_c) / DT
        s.O_dP_EE_c[:] = dP
        self._O_dP_EE_c = np.array(dP, dtype=float)
        if command is not None and generator in (
            MoveMotionGeneratorMode.kCartesianPosition, MoveMotionGeneratorMode.kCartesianVelocity
        ) and command["valid_elbow"]:
            elbow_c = np.asarray(command["elbow_c"], dtype=float)
        else:
            elbow_c = np.asarray(elbow_of(q_d))
        delbow = (elbow_c - self._elbow_c) / DT
        s.ddelbow_c[:] = (delbow - self._delbow_c) / DT
        s.delbow_c[:] = delbow
        s.elbow_c[:] = elbow_c
        self._elbow_c, self._delbow_c = np.array(elbow_c, dtype=float), delbow
