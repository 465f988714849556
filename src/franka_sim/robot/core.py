"""The FCI robot as a state machine clocked by the cycle number.

No sockets, threads or wall time here (see docs/architecture.md): the server asks the core
which joint command to apply for the next cycle, steps physics with it, and hands the measured
state back to be published. Everything the client can observe — modes, errors, desired and
commanded signals, the frames it configured — is decided here, so it can be tested in
microseconds without a network.
"""

from __future__ import annotations

import logging

import numpy as np

from franka_sim.description import hand
from franka_sim.physics.backend import JointCommand, Measured
from franka_sim.protocol.codec import StateBuffer
from franka_sim.protocol.enums import (
    AutomaticErrorRecoveryStatus,
    Command,
    ControllerMode,
    MotionGeneratorMode,
    MoveStatus,
    RobotMode,
    StopMoveStatus,
)
from franka_sim.protocol.robot_messages import build_response
from franka_sim.protocol.errors import NUM_ERRORS
from franka_sim.robot.frames import column_major, elbow_of
from franka_sim.robot.settings import Load, RobotSettings

log = logging.getLogger(__name__)

GRAVITY = np.array([0.0, 0.0, -9.81])


def idle_damping(K: np.ndarray) -> np.ndarray:
    """Damping the internal joint impedance derives from its stiffness.

    The robot's law is unpublished ("damping is derived from the stiffness"); we use critical
    damping against a nominal reflected inertia per joint (rotor + distal links), which keeps the
    explicit 1 kHz loop far inside its stability bound for every K in the allowed range.
    """
    return 2.0 * np.sqrt(K * NOMINAL_JOINT_INERTIA)


# Rough reflected inertia seen by each joint at a typical pose, kg·m² (armature + distal links);
# only used to derive impedance damping.
NOMINAL_JOINT_INERTIA = np.array([0.6, 0.6, 0.35, 0.3, 0.1, 0.1, 0.08])


class RobotCore:
    """Owns what the robot reports and decides: the session-independent robot."""

    def __init__(self, q0: np.ndarray, *, first_message_id: int = 1) -> None:
        self.settings = RobotSettings()
        self.message_id = first_message_id - 1  # id of the last published state
        self.robot_mode = RobotMode.kIdle
        self.motion_generator_mode = MotionGeneratorMode.kIdle
        self.controller_mode = ControllerMode.kJointImpedance
        self.errors = np.zeros(NUM_ERRORS, dtype=bool)
        self.reflex_reason = np.zeros(NUM_ERRORS, dtype=bool)
        self.q_hold = np.array(q0, dtype=float)
        self.measured: Measured | None = None
        self.state = StateBuffer()
        self._replies: list[bytes] = []
        self._write_constant_fields()

    # -- the cycle -------------------------------------------------------------------------
    def joint_command(self) -> JointCommand:
        """What the drives should do during the next 1 ms: hold the pose, gravity compensated."""
        K = self.settings.K_theta
        return JointCommand(
            tau_ff=np.zeros(7), q_d=self.q_hold, dq_d=np.zeros(7), K=K, D=idle_damping(K)
        )

    def publish(self, measured: Measured) -> bytes:
        """Close the cycle: record the measured state and pack the next RobotState."""
        self.message_id += 1
        self.measured = measured
        s = self.state
        s.message_id[...] = self.message_id
        F_T_EE = hand.F_T_NE_HAND @ self.settings.NE_T_EE
        O_T_EE = measured.O_T_F @ F_T_EE
        s.O_T_EE[:] = column_major(O_T_EE)
        s.O_T_EE_d[:] = s.O_T_EE
        s.O_T_EE_c[:] = s.O_T_EE
        s.F_T_EE[:] = column_major(F_T_EE)
        s.NE_T_EE[:] = column_major(self.settings.NE_T_EE)
        s.EE_T_K[:] = column_major(self.settings.EE_T_K)
        load = self.settings.load
        s.m_load[...] = load.mass
        s.F_x_Cload[:] = load.F_x_C
        s.I_load[:] = column_major(load.inertia)
        q = measured.q
        s.q[:] = q
        s.q_d[:] = q
        s.dq[:] = measured.dq
        s.tau_J[:] = measured.tau_J
        s.dtau_J[:] = measured.dtau_J
        s.theta[:] = measured.theta
        s.dtheta[:] = measured.dtheta
        elbow = elbow_of(q)
        s.elbow[:] = elbow
        s.elbow_d[:] = elbow
        s.elbow_c[:] = elbow
        s.accelerometer_top[:] = measured.accelerometer_top.ravel()
        s.accelerometer_bottom[:] = measured.accelerometer_bottom.ravel()
        s.robot_mode[...] = int(self.robot_mode)
        s.motion_generator_mode[...] = int(self.motion_generator_mode)
        s.controller_mode[...] = int(self.controller_mode)
        s.errors[:] = self.errors
        s.reflex_reason[:] = self.reflex_reason
        s.control_command_success_rate[...] = 0.0
        return s.pack()

    # -- the session's view -------------------------------------------------------------------
    @property
    def motion_running(self) -> bool:
        return False

    def client_connected(self) -> None:
        """A client completed Connect; states now stream to it."""

    def client_gone(self) -> None:
        """The client closed TCP: whatever it was doing ends, the arm holds."""
        self._replies.clear()

    def receive_command(self, command) -> bool:
        """A RobotCommand datagram from the client. True if it answered the current cycle."""
        log.info("RobotCommand for message_id %d ignored: no motion is running",
                 int(command["message_id"]))
        return False

    def take_replies(self) -> list[bytes]:
        """TCP replies the robot produced on its own (a Move's final status), in order."""
        replies, self._replies = self._replies, []
        return replies

    def request_move(self, command_id: int, request) -> list[bytes]:
        log.warning("Move refused: motion generation is not implemented yet")
        return [build_response(Command.Move, command_id, MoveStatus.kCommandNotPossibleRejected)]

    def request_stop(self, command_id: int) -> list[bytes]:
        return [build_response(Command.StopMove, command_id, StopMoveStatus.kSuccess)]

    def request_recovery(self, command_id: int) -> list[bytes]:
        self.errors[:] = False
        self.robot_mode = RobotMode.kIdle
        return [build_response(
            Command.AutomaticErrorRecovery, command_id, AutomaticErrorRecoveryStatus.kSuccess
        )]

    def set_load(self, load: Load) -> None:
        self.settings.load = load

    # -- helpers ---------------------------------------------------------------------------
    def _write_constant_fields(self) -> None:
        s = self.state
        s.F_T_NE[:] = column_major(hand.F_T_NE_HAND)
        s.m_ee[...] = hand.HAND_MASS
        s.F_x_Cee[:] = hand.HAND_COM
        s.I_ee[:] = column_major(np.asarray(hand.HAND_INERTIA))
        s.O_ddP_O[:] = GRAVITY
