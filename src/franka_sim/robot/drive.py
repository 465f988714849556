"""What the joint drives do this cycle: the robot's side of every control mode.

Idle, the arm holds its pose under the joint impedance. A running motion's generator feeds the
internal joint impedance (q_d, dq_d), or the Cartesian impedance, or the client's torque goes
straight to the drives; when the client has gone silent (enforcement off) the joint impedance
follows the motion's reference braking to rest (motion.py). A motion whose client closed its
connection is run on here, without it, until the arm has stopped (`coast`). The robot always
adds gravity compensation; a load declared with SetLoad is part of the model it compensates.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from franka_sim.physics.backend import JointCommand, Measured, Payload
from franka_sim.protocol.enums import MoveControllerMode
from franka_sim.robot.cartesian import ee_jacobian
from franka_sim.robot.controllers import cartesian_impedance_torque
from franka_sim.robot.motion import Motion
from franka_sim.robot.settings import Load, RobotSettings


class Drives:
    def __init__(self, settings: RobotSettings, q_hold: np.ndarray) -> None:
        self.settings = settings
        self.q_hold = np.array(q_hold, dtype=float)  # where the idle arm is held
        self.coasting: Motion | None = None  # a motion whose client is gone, run on to stop
        self._coast_lost = 0  # its cycles without a command, in a row
        self._payload: Payload | None = None  # the declared load, as the drives' model carries it
        self._hold: tuple | None = None  # (q_hold, K_theta, the idle command)
        self._motion_F_T_K: tuple | None = None  # (motion, EE_T_K, its F_T_EE @ EE_T_K)

    def command(self, motion: Motion | None, measured: Measured | None) -> JointCommand:
        """The drives' task for the next step (the declared load joins the compensation)."""
        command = self._task(motion, measured)
        if self._payload is None:
            return command
        return dataclasses.replace(command, load=self._payload)

    def _task(self, motion: Motion | None, measured: Measured | None) -> JointCommand:
        if motion is None or not motion.running:
            motion = self.coasting
            if motion is None:
                return self._hold_command()
        settings = self.settings
        if motion.braking:
            ref = motion.reference
            return JointCommand.impedance(ref.q_d, settings.K_theta, settings.D_theta,
                                          dq_d=ref.dq_d)
        if motion.spec.torque_controlled:
            return JointCommand.torque(motion.tau_J_d)
        if motion.spec.controller is MoveControllerMode.kCartesianImpedance:
            return JointCommand.torque(self._cartesian_impedance(motion, measured))
        ref = motion.reference
        return JointCommand.impedance(ref.q_d, settings.K_theta, settings.D_theta, dq_d=ref.dq_d,
                                      ddq_d=ref.ddq_d)

    def _hold_command(self) -> JointCommand:
        """Idle: the joint impedance about q_hold (rebuilt only when q_hold or K_theta change)."""
        hold, settings = self._hold, self.settings
        if hold is None or hold[0] is not self.q_hold or hold[1] is not settings.K_theta:
            self._hold = hold = (self.q_hold, settings.K_theta, JointCommand.impedance(
                self.q_hold, settings.K_theta, settings.D_theta, hold=True))
        return hold[2]

    def _cartesian_impedance(self, motion: Motion, m: Measured | None) -> np.ndarray:
        """kCartesianImpedance: a spring-damper at K about the desired EE pose (see controllers)."""
        kin = motion.kinematics
        if m is None or kin is None:
            return np.zeros(7)
        O_T_F_d, J_F_d = kin
        settings = self.settings
        cached = self._motion_F_T_K
        if cached is None or cached[0] is not motion or cached[1] is not settings.EE_T_K:
            cached = self._motion_F_T_K = (motion, settings.EE_T_K,
                                           motion.F_T_EE @ settings.EE_T_K)
        F_T_K = cached[2]
        # The Jacobian at q_d stands in for the one at q: they differ by the tracking error.
        J_K = ee_jacobian(m.O_T_F, J_F_d, F_T_K)
        ref = motion.reference
        # (what the robot reports as tau_J_d: the torque its controller asks, without gravity)
        motion.tau_J_d = cartesian_impedance_torque(
            settings.K_x, settings.D_x, O_T_F_d @ F_T_K, m.O_T_F @ F_T_K, J_K, m.dq,
            ref.q_d, m.q, ref.dq_d,
        )
        return motion.tau_J_d

    def hold_at(self, q: np.ndarray) -> None:
        """From now on (idle) the arm is held at q."""
        self.q_hold = q.copy()
        self.coasting = None

    def coast(self, motion: Motion, lost: int) -> None:
        """Run on a motion whose client is gone, as the robot runs any motion whose commands
        stop coming: extrapolated (its `lost` cycles in a row so far count), then braked to
        rest, where the idle hold takes over."""
        self.coasting, self._coast_lost = motion, lost

    def coast_on(self, measured: Measured | None) -> None:
        """The coasting motion's next cycle (once per cycle, before the step)."""
        motion = self.coasting
        self._coast_lost += 1
        motion.miss(self._coast_lost, measured)
        if motion.braking and motion.reference.at_rest:
            self.hold_at(motion.reference.q_d)

    def set_load(self, load: Load) -> None:
        """The load becomes part of the robot's model: gravity compensation and the estimate."""
        self.settings.load = load
        declared = load.mass > 0.0 or bool(np.any(load.inertia))
        self._payload = Payload(load.mass, np.array(load.F_x_C, float),
                                np.array(load.inertia, float)) if declared else None
