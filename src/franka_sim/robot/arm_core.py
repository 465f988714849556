"""The arm behind the FCI as a state machine clocked by the cycle number: it composes the
concepts.

No sockets, threads or wall time here (see docs/architecture.md). What every robot does alike
(the clock, the requests, a Move's lifecycle, the command window) is robot/fci.py's; this is
the arm's part of it. Per cycle `release_cycle()` closes the open cycle's command window and
says what the drives do, the physics steps, and `publish()` takes the measurement and returns
the RobotState bytes (robot/robot_cycle.py runs that sequence). TCP requests and UDP commands
arrive in between. Each concept has its own module: the status and the replies it owes
(status), recovery, Move admission, the motion and its generators, the drives, the checks and
their enforcement, the external forces, the Set* settings, and the publisher.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from franka_sim.description.hand import flange_to_ee
from franka_sim.description.urdf import ArmDescription
from franka_sim.physics.backend import JointCommand, Measured
from franka_sim.protocol.enums import (
    Command,
    GetterSetterStatus,
    MoveMotionGeneratorMode,
    MoveStatus,
    RobotMode,
)
from franka_sim.robot.admission import admit_move
from franka_sim.robot.checks import LimitPolicy, MotionGuard
from franka_sim.robot.command_window import CommandWindow
from franka_sim.robot.drive import Drives
from franka_sim.robot.events import NO_ROBOT_EVENTS, RobotEvents
from franka_sim.robot.external_forces import ExternalForces
from franka_sim.robot.fci import FciRobot
from franka_sim.robot.motion import MAX_EXTRAPOLATED_CYCLES, Motion
from franka_sim.robot.publisher import CycleFacts, StatePublisher
from franka_sim.robot.recovery import Recovery, complete_recovery, request_recovery
from franka_sim.robot.requests import set_parameter
from franka_sim.robot.settings import Load, RobotSettings

log = logging.getLogger(__name__)


class ArmCore(FciRobot):
    """The arm behind the FCI: settings, drives, checks, external forces, the state it
    publishes; the lifecycle it shares with every robot is FciRobot's."""

    def __init__(self, desc: ArmDescription, q0: np.ndarray, *, urdf: bytes = b"",
                 enforce_comm_constraints: bool = False, enforce_motion_limits: bool = False,
                 joint_discontinuity_scale: float = 1.0, first_message_id: int = 1,
                 events: RobotEvents = NO_ROBOT_EVENTS) -> None:
        super().__init__(urdf, first_message_id, events)
        self.desc = desc
        self.enforce_comm_constraints = enforce_comm_constraints
        self.joint_discontinuity_scale = joint_discontinuity_scale
        self.limit_policy = LimitPolicy(enforce_motion_limits)
        self.settings = RobotSettings()
        self.drives = Drives(self.settings, q0)
        self.external = ExternalForces()
        self.publisher = StatePublisher(self.settings)
        self.motion: Motion | None = None
        self.guard: MotionGuard | None = None
        self.measured: Measured | None = None
        self._facts = CycleFacts(self.status, self.external)
        self._recovery: Recovery | None = None
        self._silent = False  # the running motion's client missed MAX_EXTRAPOLATED_CYCLES
        self._estimate_before = None  # the external torque estimate before the last update

    # -- questions the server asks -----------------------------------------------------------
    @property
    def desired_q(self) -> np.ndarray | None:
        """Joint positions whose kinematics the published state (or a motion coasting to a
        stop) needs (None: the measured q)."""
        motion = self.motion
        if motion is None:
            motion = self.drives.coasting
            if motion is None:
                return None
        if motion.spec.generator is MoveMotionGeneratorMode.kNone:
            return None
        return motion.reference.q_d

    @property
    def busy(self) -> bool:
        """Something is under way that ends by itself: a motion, a recovery, or a lost
        client's motion coasting to a stop."""
        return (self.motion is not None or self._recovery is not None
                or self.drives.coasting is not None)

    @property
    def settled(self) -> bool:
        """Nothing here moves on by itself from one cycle to the next: nothing under way, and
        the external-force estimate stood still over the last cycle."""
        if self.busy:
            return False
        measured, external = self.measured, self.external
        if measured is None or external.untouched(measured.tau_ext):
            return True
        before = self._estimate_before
        return before is not None and np.array_equal(before, external.tau_ext_hat_filtered)

    @property
    def client_silent(self) -> bool:
        """The client went silent mid-motion and its arm is braked and held (enforcement off):
        as far as the robot can tell it is gone, so a new client may take its place."""
        return self.motion is not None and self._silent

    # -- the cycle -----------------------------------------------------------------------------
    def _idle_release(self) -> None:
        if self.drives.coasting is not None:
            self.drives.coast_on(self.measured)

    def _drive(self) -> JointCommand:
        return self.drives.command(self.motion, self.measured)  # closing may have ended it

    def publish(self, measured: Measured, desired_kinematics=None) -> bytes:
        """Close the cycle: take the measurement, advance the clock, pack the RobotState."""
        self.measured = measured
        motion = self._published()
        if motion is not None:
            motion.kinematics = desired_kinematics
            self._judge(self.guard.judge_measured, measured.q, measured.dq)
        elif self.drives.coasting is not None:
            self.drives.coasting.kinematics = desired_kinematics
        if not self.external.untouched(measured.tau_ext):
            self._estimate_before = self.external.tau_ext_hat_filtered
            self._estimate_external_forces(measured)
        if self._recovery is not None and self._recovery.done(measured.dq):
            self._recovered(measured)
        facts, motion = self._facts, self.motion
        running = motion is not None and motion.running
        facts.message_id = self.message_id
        facts.motion = motion if running else None
        facts.success_rate = self.window.success_rate if running else 0.0
        facts.measured = measured
        facts.desired_kinematics = desired_kinematics
        return self.publisher.pack(facts)

    def run_deferred_checks(self) -> None:
        """The log-only limit checks queued this cycle (see LimitPolicy): the server runs them
        once the state has left."""
        self.limit_policy.run_deferred()

    def _estimate_external_forces(self, measured: Measured) -> None:
        """External torque, wrench and flags; a collision stops a running motion (always: the
        robot's own safety, not something a client opts into)."""
        motion = self.motion if self.motion_running else None
        ddq_d = None
        if motion is not None and motion.spec.generator is not MoveMotionGeneratorMode.kNone:
            ddq_d = motion.reference.ddq_d
        reflexes = self.external.estimate(measured, self.settings, ddq_d)
        if reflexes and motion is not None:
            log.warning("collision (external force over the upper threshold): %s",
                        ", ".join(reflexes))
            self._reflex(reflexes)

    def _close_window(self, motion: Motion) -> None:
        self.limit_policy.run_deferred()  # the last cycle's first: the checks difference samples
        command = self.window.close()
        if command is None and motion.spec.use_async:
            # A target counts whenever it comes: libfranka's async handler sends each one once,
            # answering the last state its program read, which may be long gone.
            command = self.window.late
        lost = self.window.consecutive_lost
        guard = self.guard
        guard.released()
        if command is not None:
            if self._judge(guard.judge_command, command, motion.reference.q_d, motion.braking):
                return  # a violating command never reaches the physics
            motion.apply(command)
            self._silent = False
        elif (motion.last_command is not None or motion.spec.use_async
              or lost > MAX_EXTRAPOLATED_CYCLES):
            motion.miss(lost, self.measured)
        # else: no command yet, the motion holds its start (so however many states a client's
        # start-motion handshake happened to read first, its first command meets the same arm)
        if (motion.cartesian is not None and not motion.braking
                and self._judge(guard.judge_ik, motion.reference)):
            return
        if lost >= MAX_EXTRAPOLATED_CYCLES and not motion.spec.use_async:
            if self.enforce_comm_constraints:
                log.warning("%d consecutive command cycles lost: "
                            "communication_constraints_violation", lost)
                self._reflex(["communication_constraints_violation"])
                return
            if lost == MAX_EXTRAPOLATED_CYCLES:
                log.warning(self.window.silence(
                    "braking the arm to rest", "held until the client is heard again"))
            self._silent = True
        if command is not None and motion.finished:
            self._finish(motion)
        elif ((self._silent or motion.spec.use_async) and self.window.late is not None
              and motion.asks_to_finish(self.window.late) and not motion.still_moving()):
            # Heard, but only late: libfranka sends its finish again each cycle until the
            # state shows the motion ended, and would wait for ever for a robot that does not
            # abort. Its values stay dropped; the arm held (braked to rest, or an async
            # generator arrived) ends the motion.
            log.warning("motion finished by a late command (the arm held where it was)")
            self._finish(motion)

    def _judge(self, check, *args) -> bool:
        """A limit check under the enforce-or-log policy; True: the motion was aborted."""
        names = self.limit_policy.judge(check, *args)
        if names:
            self._reflex(names)
            return True
        return False

    # -- TCP requests ----------------------------------------------------------------------------
    def _admit(self, command_id: int, request) -> Motion:
        measured = self.measured
        q = measured.q if measured is not None else self.drives.q_hold
        return admit_move(
            self.desc, command_id, request, running=self.motion is not None,
            robot_mode=self.status.robot_mode, q=q,
            O_T_F=None if measured is None else measured.O_T_F,
            F_T_EE=flange_to_ee(self.settings.NE_T_EE))

    def _started(self, motion: Motion) -> None:
        start = self.publisher.published_start()  # what the client saw, as it will echo it
        self.guard = MotionGuard(
            self.desc, motion.spec, q_start=start.q, O_T_EE_start=start.O_T_EE,
            elbow_start=start.elbow, joint_discontinuity_scale=self.joint_discontinuity_scale)
        self._silent = False
        self.drives.coasting = None  # a lost client's motion still stopping: this one takes over

    def _set(self, command: Command, request) -> GetterSetterStatus:
        return set_parameter(self, command, request)

    def request_recovery(self, command_id: int) -> list[bytes]:
        replies, self._recovery = request_recovery(self.status, self.external, self._recovery,
                                                   command_id)
        return replies

    def set_load(self, load: Load) -> None:
        self.drives.set_load(load)

    # -- from outside the FCI ----------------------------------------------------------------------
    def reset(self, q: np.ndarray, measured: Measured, message_id: int | None = None) -> None:
        """The robot as it powers up, at rest at q (whose measurement is `measured`): no error,
        Idle, no external force on record, every Set* setting at its default. Only between
        motions (ValueError otherwise). The clock goes on; `message_id`: the last state that
        left, when a released cycle whose state had not is taken back."""
        if self.motion is not None or self._recovery is not None:
            raise ValueError("a motion or an error recovery is under way")
        if message_id is not None:
            self.message_id = message_id
        self.start_reads = None  # (how a client starts is yet to be seen, as when powered up)
        defaults = RobotSettings()
        for setting in dataclasses.fields(defaults):
            if setting.init:
                setattr(self.settings, setting.name, getattr(defaults, setting.name))
        self.drives.set_load(self.settings.load)
        self.drives.hold_at(q)
        status = self.status
        status.reflex_reason[:] = False
        status.clear_errors()
        status.robot_mode = RobotMode.kIdle
        status.take_replies()
        self.external.reset()
        self.window = CommandWindow()
        self.guard = None
        self.measured = measured

    def hold(self, held: bool, why: str = "the Desk holds the arm") -> None:
        """The Desk locks the brakes or leaves Execution (held: `why`), or frees the arm again.
        A running motion ends as one the robot stops itself (kAborted), the arm held where it
        is, and the log says why."""
        if held and self.motion is not None:
            log.warning("Move aborted: %s", why)
            self.status.answer_move(self.motion.command_id, MoveStatus.kAborted)
            self._end_motion(RobotMode.kIdle)
        self.status.held = held
        self.status.flags_version += 1

    # -- the session's view ----------------------------------------------------------------------
    def client_gone(self) -> None:
        """The client closed TCP. Under enforcement its motion ends in the reflex. Without, the
        robot runs it on as it runs any motion whose commands stop coming (extrapolated, then
        braked to rest: Drives.coast), but reports idle at once: nobody is left to answer, and
        the next client may start its own motion straight away."""
        motion = self.motion
        if motion is not None:
            if self.enforce_comm_constraints and motion.running:
                log.warning("the client left during its motion: "
                            "communication_constraints_violation")
                self._reflex(["communication_constraints_violation"])
            elif motion.running:
                motion.orphaned = True
                self.motion = None
                self._silent = False
                self.status.robot_mode = RobotMode.kIdle
                self.drives.coast(motion, self.window.consecutive_lost)
            else:
                self._end_motion(RobotMode.kIdle)
        self._recovery = None
        if self.status.robot_mode is RobotMode.kAutomaticErrorRecovery:
            self.status.robot_mode = RobotMode.kReflex
        self.status.take_replies()

    # -- transitions -----------------------------------------------------------------------------
    def _finish(self, motion: Motion) -> None:
        if motion.still_moving():
            log.warning("motion finished while the generator still moves: aborted")
            self.status.answer_move(motion.command_id, MoveStatus.kReflexAborted)
            self._end_motion(RobotMode.kIdle)
            return
        self.status.answer_move(motion.command_id, MoveStatus.kSuccess)
        if not motion.spec.torque_controlled:
            self.drives.hold_at(motion.reference.q_d)
            self.motion = None
            self.status.robot_mode = RobotMode.kIdle
        else:
            self._end_motion(RobotMode.kIdle)

    def _reflex(self, names: list[str]) -> None:
        self.status.latch(names)
        if self.motion is not None:
            self.status.answer_move(self.motion.command_id, MoveStatus.kReflexAborted)
        self._end_motion(RobotMode.kReflex)

    def _end_motion(self, mode: RobotMode) -> None:
        """Stop where the arm is: the impedance hold brings it to rest."""
        self.motion = None
        self._silent = False
        self.status.robot_mode = mode
        if self.measured is not None:
            self.drives.hold_at(self.measured.q)

    def _recovered(self, measured: Measured) -> None:
        recovery, self._recovery = self._recovery, None
        complete_recovery(recovery, self.status, self.external, self.drives, measured)
