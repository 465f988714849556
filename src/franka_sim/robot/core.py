"""The FCI robot as a state machine clocked by the cycle number.

No sockets, threads or wall time here (see docs/architecture.md). Per cycle the server calls
`joint_command()` when it releases the cycle (that closes the previous cycle's command window),
steps physics with the result, and hands the measurement to `publish()`, which returns the
RobotState bytes. TCP requests and UDP commands arrive in between. Everything a client can
observe — modes, errors, desired signals, the frames it configured, Move replies — is decided
here, so it is testable in microseconds without a network.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from franka_sim.description import hand
from franka_sim.description.kinematics import flange_pose, tip_jacobian
from franka_sim.description.urdf import ArmDescription
from franka_sim.physics.backend import JointCommand, Measured, Payload
from franka_sim.protocol.codec import non_finite_command_fields
from franka_sim.protocol.enums import (
    AutomaticErrorRecoveryStatus,
    Command,
    ControllerMode,
    MotionGeneratorMode,
    MoveControllerMode,
    MoveMotionGeneratorMode,
    MoveStatus,
    RobotMode,
    StopMoveStatus,
)
from franka_sim.protocol.errors import NUM_ERRORS, error_index
from franka_sim.protocol.robot_messages import build_response
from franka_sim.robot.command_cycle import CommandCycle
from franka_sim.robot.cartesian import (
    SINGULAR_POSE_MIN_SINGULAR_VALUE,
    ee_jacobian,
    smallest_singular_value,
)
from franka_sim.robot.controllers import cartesian_impedance_torque
from franka_sim.robot.external_forces import ExternalForces, accelerating, active_thresholds
from franka_sim.robot.motion_guard import MotionGuard, ViolationLog, error_names
from franka_sim.robot.motion import (
    CARTESIAN_GENERATORS,
    MAX_EXTRAPOLATED_CYCLES,
    Motion,
    MoveRejected,
    MoveSpec,
    parse_move,
)
from franka_sim.robot.publisher import StatePublisher
from franka_sim.robot.settings import Load, RobotSettings

log = logging.getLogger(__name__)

# Recovery waits for the arm to stop before it answers, at most this long (the robot's
# answer time is bounded well inside libfranka's 1 s TCP timeout).
RECOVERY_MAX_CYCLES = 700
RECOVERY_REST_VELOCITY = 1e-3  # rad/s

class RobotCore:
    """The robot behind the FCI: settings, modes, errors, the running motion, the state."""

    def __init__(self, desc: ArmDescription, q0: np.ndarray, *,
                 enforce_comm_constraints: bool = False, enforce_motion_limits: bool = False,
                 joint_discontinuity_scale: float = 1.0, first_message_id: int = 1) -> None:
        self.desc = desc
        self.enforce_motion_limits = enforce_motion_limits
        self.joint_discontinuity_scale = joint_discontinuity_scale
        self.guard: MotionGuard | None = None
        self.violations = ViolationLog()
        self.settings = RobotSettings()
        self.enforce_comm_constraints = enforce_comm_constraints
        self.message_id = first_message_id - 1  # id of the last published state
        self.robot_mode = RobotMode.kIdle
        self.errors = np.zeros(NUM_ERRORS, dtype=bool)
        self.reflex_reason = np.zeros(NUM_ERRORS, dtype=bool)
        self.flags_version = 0  # moves whenever errors or reflex_reason change (publisher)
        self.q_hold = np.array(q0, dtype=float)
        self.measured: Measured | None = None
        self.motion: Motion | None = None
        self.cycle = CommandCycle()
        self.publisher = StatePublisher(self.settings)
        self._replies: list[bytes] = []
        # (the command_ids waiting for the answer, cycles waited): a raw client may ask twice
        self._recovery: tuple[list[int], int] | None = None
        self._stray_commands = 0  # this session's: each client's first one is logged
        self._stalled_at: np.ndarray | None = None
        self._hold: tuple | None = None
        self.external = ExternalForces()
        self._payload: Payload | None = None  # the declared load, as the drives' model carries it
        self._F_T_K: tuple | None = None  # (NE_T_EE, EE_T_K, F_T_K), rebuilt when they change
        self._motion_F_T_K: tuple | None = None  # (motion, EE_T_K, its F_T_EE @ EE_T_K)
        self._window_closed = False  # the open cycle's command window was closed early
        # Limit checks whose only outcome is a log line (limits not enforced): (check, *args),
        # run once the state has left (run_deferred_checks), in the order they were queued.
        self._deferred_checks: list[tuple] = []

    # -- the cycle ---------------------------------------------------------------------------
    def joint_command(self) -> JointCommand:
        """Release the next cycle: close the command window if still open, decide the drives'
        task. Idempotent until the next publish (a second call only recomputes)."""
        command = self._drives_task()
        if self._payload is None:
            return command
        return dataclasses.replace(command, load=self._payload)  # in the gravity compensation

    def _drives_task(self) -> JointCommand:
        motion = self.motion
        if motion is not None and motion.running and not self._window_closed:
            self._window_closed = True
            self._close_cycle(motion)
        motion = self.motion  # closing may have ended it
        if motion is None or not motion.running:
            return self._hold_command()
        settings = self.settings
        if self._stalled_at is not None:
            return JointCommand.impedance(self._stalled_at, settings.K_theta, settings.D_theta)
        if motion.spec.torque_controlled:
            return JointCommand.torque(motion.tau_J_d)
        if motion.spec.controller is MoveControllerMode.kCartesianImpedance:
            return JointCommand.torque(self._cartesian_impedance(motion))
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

    def _cartesian_impedance(self, motion: Motion) -> np.ndarray:
        """kCartesianImpedance: a spring-damper at K about the desired EE pose (see controllers)."""
        m, kin = self.measured, motion.kinematics
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
        return cartesian_impedance_torque(
            settings.K_x, settings.D_x, O_T_F_d @ F_T_K, m.O_T_F @ F_T_K, J_K, m.dq,
            motion.reference.q_d, m.q,
        )

    def publish(self, measured: Measured, desired_kinematics=None) -> bytes:
        """Close the cycle: take the measurement, advance the clock, pack the RobotState."""
        self.message_id += 1
        self.measured = measured
        motion = self.motion
        if motion is not None:
            if not motion.running:
                motion.running = True  # the modes flip on the first state after kMotionStarted
                self.robot_mode = RobotMode.kMove
                self.reflex_reason[:] = False
                self.flags_version += 1
            self.cycle.opened(self.message_id)
            self._window_closed = False
            motion.kinematics = desired_kinematics
            self._judge(self.guard.judge_measured, measured.q, measured.dq)
        if not self.external.untouched(measured.tau_ext):
            self._estimate_external_forces(measured)
        if self._recovery is not None:
            self._advance_recovery(measured)
        return self.publisher.pack(self, measured, desired_kinematics)

    def _estimate_external_forces(self, measured: Measured) -> None:
        """External torque, wrench and flags; a collision stops a running motion (always: the
        robot's own safety, not something a client opts into)."""
        motion = self.motion if self.motion_running else None
        ddq_d = None
        if motion is not None and motion.spec.generator is not MoveMotionGeneratorMode.kNone:
            ddq_d = motion.reference.ddq_d
        thresholds = active_thresholds(self.settings.collision, accelerating(ddq_d))
        reflexes = self.external.update(measured.tau_ext, measured.O_T_F, measured.J_F,
                                        self._flange_to_K(), thresholds)
        if reflexes and motion is not None:
            log.warning("collision (external force over the upper threshold): %s",
                        ", ".join(reflexes))
            self._reflex(reflexes)

    def _flange_to_K(self) -> np.ndarray:
        settings = self.settings
        cached = self._F_T_K
        if (cached is None or cached[0] is not settings.NE_T_EE
                or cached[1] is not settings.EE_T_K):
            cached = self._F_T_K = (settings.NE_T_EE, settings.EE_T_K,
                                    hand.F_T_NE_HAND @ settings.NE_T_EE @ settings.EE_T_K)
        return cached[2]

    @property
    def motion_running(self) -> bool:
        return self.motion is not None and self.motion.running

    @property
    def desired_q(self) -> np.ndarray | None:
        """Joint positions whose kinematics the published state needs (None: the measured q)."""
        motion = self.motion
        if motion is None or motion.spec.generator is MoveMotionGeneratorMode.kNone:
            return None
        return motion.reference.q_d

    @property
    def state_modes(self) -> tuple[MotionGeneratorMode, ControllerMode]:
        if self.motion is not None and self.motion.running:
            return self.motion.spec.state_modes
        return MotionGeneratorMode.kIdle, ControllerMode.kJointImpedance

    @property
    def success_rate(self) -> float:
        return self.cycle.success_rate if self.motion_running else 0.0

    def _close_cycle(self, motion: Motion) -> None:
        self.run_deferred_checks()  # the last cycle's first: the checks difference samples
        command = self.cycle.close()
        lost = self.cycle.consecutive_lost
        guard = self.guard
        guard.released()
        if command is not None:
            if self._judge(guard.judge_command, command):
                return  # a violating command never reaches the physics
            motion.apply(command)
            self._stalled_at = None
        else:
            motion.miss(lost)
        if motion.cartesian is not None and self._judge(guard.judge_ik, motion.reference):
            return
        if lost >= MAX_EXTRAPOLATED_CYCLES and not motion.spec.use_async:
            if self.enforce_comm_constraints:
                log.warning("%d consecutive command cycles lost: communication_constraints_violation", lost)
                self._reflex(["communication_constraints_violation"])
                return
            if lost == MAX_EXTRAPOLATED_CYCLES:
                log.warning("client silent for %d cycles: holding the arm until it is heard again", lost)
            if self._stalled_at is None and self.measured is not None:
                self._stalled_at = self.measured.q.copy()
        if command is not None and motion.finished:
            self._finish(motion)

    def _judge(self, check, *args) -> bool:
        """Run a limit check now if its violations abort the motion (True: it aborted);
        otherwise queue it: its only outcome is a log line, which need not hold up the state
        a client is waiting for (a lockstep cycle is ~7 % faster without them)."""
        if not self.enforce_motion_limits:
            self._deferred_checks.append((check, *args))
            return False
        return self._enforce(check(*args))

    def run_deferred_checks(self) -> None:
        """The queued log-only checks (see _judge): the server runs them once the state has
        left; the next cycle runs any left over first, so their order never changes."""
        queued = self._deferred_checks
        if not queued:
            return
        self._deferred_checks = []
        for check, *args in queued:
            self._enforce(check(*args))

    def _enforce(self, violations) -> bool:
        """Log violations; with enforcement, abort on any that the robot aborts on."""
        if not violations:
            return False
        self.violations.report(violations, self.enforce_motion_limits)
        names = error_names(violations)
        if names and self.enforce_motion_limits:
            self._reflex(names)
            return True
        return False

    # -- UDP commands ----------------------------------------------------------------------------
    def receive_command(self, command) -> bool:
        """A RobotCommand datagram from the client. True if it answered the open cycle in time."""
        motion = self.motion
        message_id = int(command["message_id"])
        if motion is None or not motion.running:
            self._stray_commands += 1
            if self._stray_commands in (1, 100) or self._stray_commands % 10000 == 0:
                log.info("RobotCommand for message_id %d ignored: no motion is running (%d so far)",
                         message_id, self._stray_commands)
            return False
        bad = non_finite_command_fields(command)
        if bad:
            log.warning("RobotCommand for message_id %d dropped: non-finite %s",
                        message_id, ", ".join(bad))
            return False
        on_time = self.cycle.receive(message_id, command)
        if on_time and not self._window_closed:
            # The answer is in: the window closes now, so the next cycle's command is known
            # before its deadline (the server can release it without asking again).
            self._window_closed = True
            self._close_cycle(motion)
        return on_time

    # -- TCP requests ----------------------------------------------------------------------------
    def request_move(self, command_id: int, request) -> list[bytes]:
        try:
            spec = parse_move(request)
            self._check_can_move(spec)
        except MoveRejected as exc:
            log.warning("Move rejected (%s): %s", exc.status.name, exc)
            return [build_response(Command.Move, command_id, exc.status)]
        q = self.measured.q if self.measured is not None else self.q_hold
        F_T_EE = hand.F_T_NE_HAND @ self.settings.NE_T_EE
        O_T_EE = (self.measured.O_T_F if self.measured is not None
                  else flange_pose(self.desc, q)) @ F_T_EE
        self.motion = Motion(command_id, spec, q, O_T_EE, F_T_EE)
        seen = self.publisher.buffer  # the start the client saw (float32, as it will echo it)
        self.guard = MotionGuard(
            self.desc, spec, q_start=np.array(seen.q, dtype=float),
            O_T_EE_start=np.array(seen.O_T_EE, dtype=float),
            elbow_start=np.array(seen.elbow, dtype=float),
            joint_discontinuity_scale=self.joint_discontinuity_scale,
        )
        self.cycle = CommandCycle()
        self._stalled_at = None
        return [build_response(Command.Move, command_id, MoveStatus.kMotionStarted)]

    def _check_can_move(self, spec: MoveSpec) -> None:
        if self.motion is not None:
            raise MoveRejected(MoveStatus.kCommandNotPossibleRejected, "a motion is already running")
        if self.robot_mode is not RobotMode.kIdle:
            raise MoveRejected(MoveStatus.kCommandNotPossibleRejected,
                               f"robot is in {self.robot_mode.name}; recover first")
        if spec.generator in CARTESIAN_GENERATORS:
            q = self.measured.q if self.measured is not None else self.q_hold
            F_T_EE = hand.F_T_NE_HAND @ self.settings.NE_T_EE
            sigma = smallest_singular_value(tip_jacobian(self.desc, q, F_T_EE))
            if sigma < SINGULAR_POSE_MIN_SINGULAR_VALUE:
                raise MoveRejected(
                    MoveStatus.kStartAtSingularPoseRejected,
                    f"EE Jacobian's smallest singular value {sigma:.4f} < "
                    f"{SINGULAR_POSE_MIN_SINGULAR_VALUE}: cannot start at a singular pose",
                )

    def request_stop(self, command_id: int) -> list[bytes]:
        replies = []
        if self.motion is not None:
            replies.append(build_response(Command.Move, self.motion.command_id, MoveStatus.kPreempted))
            self._end_motion(RobotMode.kIdle)
        replies.append(build_response(Command.StopMove, command_id, StopMoveStatus.kSuccess))
        return replies

    def request_recovery(self, command_id: int) -> list[bytes]:
        if self.robot_mode is RobotMode.kMove:
            return [build_response(Command.AutomaticErrorRecovery, command_id,
                                   AutomaticErrorRecoveryStatus.kCommandNotPossibleRejected)]
        if not self.errors.any() and self.robot_mode is RobotMode.kIdle:
            self.external.clear_collisions()
            return [build_response(Command.AutomaticErrorRecovery, command_id,
                                   AutomaticErrorRecoveryStatus.kSuccess)]
        self.robot_mode = RobotMode.kAutomaticErrorRecovery
        if self._recovery is None:
            self._recovery = ([command_id], 0)
        else:  # one more request for the recovery under way: answered with it
            self._recovery[0].append(command_id)
        return []  # answered once the arm is at rest (see _advance_recovery)

    def set_load(self, load: Load) -> None:
        """The load becomes part of the robot's model: gravity compensation and the estimate."""
        self.settings.load = load
        declared = load.mass > 0.0 or bool(np.any(load.inertia))
        self._payload = Payload(load.mass, np.array(load.F_x_C, float),
                                np.array(load.inertia, float)) if declared else None

    # -- the session's view ----------------------------------------------------------------------
    def client_connected(self) -> None:
        """A client completed Connect; states now stream to it (and its first stray command
        is logged, whatever earlier clients sent)."""
        self._stray_commands = 0

    def client_gone(self) -> None:
        """The client closed TCP: its motion ends as if it went silent, and the arm holds."""
        if self.motion is not None:
            if self.enforce_comm_constraints and self.motion.running:
                self._reflex(["communication_constraints_violation"])
            else:
                self._end_motion(RobotMode.kIdle)
        self._recovery = None
        if self.robot_mode is RobotMode.kAutomaticErrorRecovery:
            self.robot_mode = RobotMode.kReflex
        self._replies.clear()

    @property
    def client_silent(self) -> bool:
        """The client went silent mid-motion and its arm is held (enforcement off): as far as
        the robot can tell it is gone, so a new client may take its place."""
        return self.motion is not None and self._stalled_at is not None

    @property
    def has_replies(self) -> bool:
        return bool(self._replies)

    def take_replies(self) -> list[bytes]:
        """TCP replies the robot produced on its own (a Move's final status), in order."""
        replies, self._replies = self._replies, []
        return replies

    # -- transitions -----------------------------------------------------------------------------
    def _finish(self, motion: Motion) -> None:
        if motion.still_moving():
            log.warning("motion finished while the generator still moves: aborted")
            self._replies.append(build_response(Command.Move, motion.command_id, MoveStatus.kReflexAborted))
            self._end_motion(RobotMode.kIdle)
            return
        self._replies.append(build_response(Command.Move, motion.command_id, MoveStatus.kSuccess))
        if not motion.spec.torque_controlled:
            self.q_hold = motion.reference.q_d.copy()
            self.motion = None
            self.robot_mode = RobotMode.kIdle
        else:
            self._end_motion(RobotMode.kIdle)

    def _reflex(self, names: list[str]) -> None:
        for name in names:
            self.errors[error_index(name)] = True
            self.reflex_reason[error_index(name)] = True
        self.flags_version += 1
        if self.motion is not None:
            self._replies.append(
                build_response(Command.Move, self.motion.command_id, MoveStatus.kReflexAborted)
            )
        self._end_motion(RobotMode.kReflex)

    def _end_motion(self, mode: RobotMode) -> None:
        """Stop where the arm is: the impedance hold brings it to rest."""
        self.motion = None
        self._stalled_at = None
        self.robot_mode = mode
        if self.measured is not None:
            self.q_hold = self.measured.q.copy()

    def _advance_recovery(self, measured: Measured) -> None:
        if self._recovery is None:
            return
        command_ids, waited = self._recovery
        at_rest = float(np.max(np.abs(measured.dq))) < RECOVERY_REST_VELOCITY
        if not at_rest and waited < RECOVERY_MAX_CYCLES:
            self._recovery = (command_ids, waited + 1)
            return
        self._recovery = None
        self.errors[:] = False
        self.flags_version += 1
        self.external.clear_collisions()
        self.robot_mode = RobotMode.kIdle
        self.q_hold = measured.q.copy()
        self._replies.extend(build_response(
            Command.AutomaticErrorRecovery, command_id, AutomaticErrorRecoveryStatus.kSuccess)
            for command_id in command_ids)
