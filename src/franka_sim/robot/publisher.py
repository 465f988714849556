"""Fills the RobotState from the robot's decisions and the measurement, once per cycle.

Only fields that change are written each cycle (each write costs ~0.3 µs); constant ones
(hand inertials, gravity) once. The desired-side kinematics (O_T_EE_d and the Jacobian at q_d)
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
from franka_sim.robot.frames import column_major, elbow_of
from franka_sim.robot.settings import RobotSettings

if TYPE_CHECKING:
    from franka_sim.robot.core import RobotCore

GRAVITY = np.array([0.0, 0.0, -9.81])
DT = 1e-3


def ee_twist(O_T_F: np.ndarray, J_F: np.ndarray, F_T_EE: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """Twist of the EE point in the base frame from the flange Jacobian."""
    twist = J_F @ dq
    r = O_T_F[:3, :3] @ F_T_EE[:3, 3]
    twist[:3] += np.cross(twist[3:], r)
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

    def pack(self, core: "RobotCore", m: Measured, desired_kinematics) -> bytes:
        s, settings = self.buffer, self.settings
        s.message_id[...] = core.message_id
        F_T_EE = hand.F_T_NE_HAND @ settings.NE_T_EE
        O_T_EE = m.O_T_F @ F_T_EE
        s.O_T_EE[:] = column_major(O_T_EE)
        s.F_T_EE[:] = column_major(F_T_EE)
        s.NE_T_EE[:] = column_major(settings.NE_T_EE)
        s.EE_T_K[:] = column_major(settings.EE_T_K)
        load = settings.load
        s.m_load[...] = load.mass
        s.F_x_Cload[:] = load.F_x_C
        s.I_load[:] = column_major(load.inertia)

        s.q[:] = m.q
        s.dq[:] = m.dq
        s.tau_J[:] = m.tau_J
        s.dtau_J[:] = m.dtau_J
        s.theta[:] = m.theta
        s.dtheta[:] = m.dtheta
        s.accelerometer_top[:] = m.accelerometer_top.ravel()
        s.accelerometer_bottom[:] = m.accelerometer_bottom.ravel()

        motion = core.motion if core.motion_running else None
        q_d = core.desired_q
        if q_d is None:
            q_d, dq_d, ddq_d = m.q, (m.dq if motion is not None else np.zeros(7)), np.zeros(7)
        else:
            ref = motion.reference
            dq_d, ddq_d = ref.dq_d, ref.ddq_d
        s.q_d[:] = q_d
        s.dq_d[:] = dq_d
        s.ddq_d[:] = ddq_d
        if motion is None:
            tau_J_d = np.zeros(7)
        elif motion.spec.torque_controlled:
            tau_J_d = motion.tau_J_d
        else:  # the internal impedance's torque, without gravity (as the robot defines tau_J_d)
            tau_J_d = impedance_torque(settings.K_theta, q_d, dq_d, m.q, m.dq)
        s.tau_J_d[:] = tau_J_d

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
        mg, ctrl = core.state_modes
        s.motion_generator_mode[...] = int(mg)
        s.controller_mode[...] = int(ctrl)
        s.robot_mode[...] = int(core.robot_mode)
        s.errors[:] = core.errors
        s.reflex_reason[:] = core.reflex_reason
        s.control_command_success_rate[...] = core.success_rate
        return s.pack()

    def _commanded_cartesian(self, motion, O_T_EE_d, O_dP_EE_d, q_d) -> None:
        """The c-signals: the client's own Cartesian stream if it drives one, else the d-signals."""
        s = self.buffer
        command = motion.last_command if motion is not None else None
        generator = motion.spec.generator if motion is not None else None
        if command is not None and generator is MoveMotionGeneratorMode.kCartesianPosition:
            s.O_T_EE_c[:] = command["O_T_EE_c"]
        else:
            s.O_T_EE_c[:] = column_major(O_T_EE_d)
        if command is not None and generator is MoveMotionGeneratorMode.kCartesianVelocity:
            dP = np.asarray(command["O_dP_EE_c"], dtype=float)
        else:
            dP = O_dP_EE_d
        s.O_ddP_EE_c[:] = (dP - self._O_dP_EE_c) / DT if motion is not None else 0.0
        s.O_dP_EE_c[:] = dP
        self._O_dP_EE_c = np.array(dP, dtype=float)
        if command is not None and generator in (
            MoveMotionGeneratorMode.kCartesianPosition, MoveMotionGeneratorMode.kCartesianVelocity
        ) and command["valid_elbow"]:
            elbow_c = np.asarray(command["elbow_c"], dtype=float)
        else:
            elbow_c = np.asarray(elbow_of(q_d))
        delbow = (elbow_c - self._elbow_c) / DT if motion is not None else np.zeros(2)
        s.ddelbow_c[:] = (delbow - self._delbow_c) / DT if motion is not None else 0.0
        s.delbow_c[:] = delbow
        s.elbow_c[:] = elbow_c
        self._elbow_c, self._delbow_c = elbow_c, delbow
