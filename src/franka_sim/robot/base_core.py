"""The mobile base behind its own FCI endpoint, sans-IO, clocked by the cycle number.

libfranka has no protocol of its own for a base: a mobile robot speaks the arm's v10 protocol
and is driven by the ordinary Cartesian-velocity motion, whose O_dP_EE_c is the base's body
twist (vx, vy, wz; Franka's ROS 2 driver writes only these). So this core answers the arm's
requests with what a base can do:

- Connect and GetRobotModel as an arm (the URDF names a "tmr" robot, so libfranka >= 0.21
  calls it mobile and refuses loadModel()); the Set* requests are taken and change nothing;
- Move: only the Cartesian-velocity generator under an internal controller; any other is
  refused with kCommandNotPossibleRejected;
- each cycle the command window decides which twist applies (as on an arm: a missed cycle
  keeps the last one, and after MAX_EXTRAPOLATED_CYCLES lost the base brakes until the client
  is heard again, or with `enforce_comm_constraints` the motion ends in the reflex
  communication_constraints_violation, as an arm's does); a twist with vz, wx or wy is a reflex
  (cartesian_motion_generator_velocity_limits_violation), recovered by
  AutomaticErrorRecovery;
- a finished motion, StopMove or a client gone leaves the base braking to rest.
The drive itself (limits, pose, swerve modules) is robot/swerve.py; the state, base_state.py.
"""

from __future__ import annotations

import logging

from franka_sim.protocol.enums import (AutomaticErrorRecoveryStatus, Command,
                                       GetterSetterStatus, MoveControllerMode,
                                       MoveMotionGeneratorMode, MoveStatus, RobotMode)
from franka_sim.protocol.robot_messages import build_response
from franka_sim.robot.base_state import BaseStatePublisher
from franka_sim.robot.events import NO_ROBOT_EVENTS, RobotEvents
from franka_sim.robot.fci import FciRobot
from franka_sim.robot.motion import MAX_EXTRAPOLATED_CYCLES, MoveRejected, MoveSpec, parse_move
from franka_sim.robot.swerve import SwerveDrive

log = logging.getLogger(__name__)

PLANAR_TOLERANCE = 1e-6  # m/s, rad/s: what vz, wx and wy may be without a reflex
PLANAR_REFLEX = "cartesian_motion_generator_velocity_limits_violation"
COMM_REFLEX = "communication_constraints_violation"


class BaseMotion:
    """A running base motion: its Move's id and modes, and the client's last command."""

    __slots__ = ("command_id", "spec", "running", "first_state", "last_command", "twist_c",
                 "braking")

    def __init__(self, command_id: int, spec: MoveSpec) -> None:
        self.command_id, self.spec = command_id, spec
        self.running = False  # the modes flip on the first state after kMotionStarted
        self.first_state = -1
        self.last_command = None  # None until the client's first command
        self.twist_c: tuple | None = None  # its twist
        self.braking = False  # its client fell silent: the base brakes until it is heard


class BaseCore(FciRobot):
    """The base's part of the FCI lifecycle (robot/fci.py): its Moves, its drive, its state."""

    def __init__(self, urdf: bytes, first_message_id: int = 1,
                 events: RobotEvents = NO_ROBOT_EVENTS, *,
                 enforce_comm_constraints: bool = False) -> None:
        super().__init__(urdf, first_message_id, events)
        self.enforce_comm_constraints = enforce_comm_constraints
        self.drive = SwerveDrive()
        self.publisher = BaseStatePublisher()
        self.motion: BaseMotion | None = None
        self._target = (0.0, 0.0, 0.0)  # the body twist the drive follows

    # -- questions the server asks -------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """A motion, or the base still braking to rest."""
        return self.motion is not None or self.drive.moving

    @property
    def client_silent(self) -> bool:
        """Its motion's client lost MAX_EXTRAPOLATED_CYCLES in a row: a new one may take over."""
        return (self.motion_running
                and self.window.consecutive_lost >= MAX_EXTRAPOLATED_CYCLES)

    # -- the cycle -----------------------------------------------------------------------------
    def _drive(self) -> tuple[float, float, float]:
        """Move the base one cycle; its planar pose (x, y, yaw)."""
        drive = self.drive
        drive.step(*self._target)
        return drive.x, drive.y, drive.yaw

    def publish(self) -> bytes:
        motion = self._published()
        if motion is not None:
            return self.publisher.pack(self.message_id, self.drive, motion.twist_c,
                                       self.status.robot_mode, self.window.success_rate,
                                       motion.spec.state_modes, self.status)
        return self.publisher.pack(self.message_id, self.drive, None, self.status.robot_mode,
                                   0.0, None, self.status)

    def _close_window(self, motion: BaseMotion) -> None:
        command = self.window.close()
        motion.braking = command is None and (
            self.window.consecutive_lost >= MAX_EXTRAPOLATED_CYCLES)
        if command is None:
            if motion.braking and self.enforce_comm_constraints:
                log.warning("%d consecutive command cycles lost: %s",
                            self.window.consecutive_lost, COMM_REFLEX)
                self._reflex(motion, COMM_REFLEX)
                return
            if motion.braking:
                if self.window.consecutive_lost == MAX_EXTRAPOLATED_CYCLES:
                    log.warning(self.window.silence(
                        "braking to rest", "until the client is heard again"))
                self._target = (0.0, 0.0, 0.0)
                late = self.window.late
                if late is not None and late["motion_generation_finished"]:
                    # Heard only late (the arm's reason, robot/arm_core.py): the finish ends it.
                    log.warning("motion finished by a late command")
                    self.status.answer_move(motion.command_id, MoveStatus.kSuccess)
                    self._end_motion(RobotMode.kIdle)
            return
        twist = tuple(float(v) for v in command["O_dP_EE_c"])
        motion.last_command, motion.twist_c = command, twist
        vx, vy, vz, wx, wy, wz = twist
        if max(abs(vz), abs(wx), abs(wy)) > PLANAR_TOLERANCE:
            log.warning("base twist has vz/wx/wy %.3g/%.3g/%.3g: a base moves in the plane "
                        "only (%s)", vz, wx, wy, PLANAR_REFLEX)
            self._reflex(motion, PLANAR_REFLEX)
            return
        self._target = (vx, vy, wz)
        if bool(command["motion_generation_finished"]):
            self.status.answer_move(motion.command_id, MoveStatus.kSuccess)
            self._end_motion(RobotMode.kIdle)

    def _reflex(self, motion: BaseMotion, error: str) -> None:
        self.status.latch([error])
        self.status.answer_move(motion.command_id, MoveStatus.kReflexAborted)
        self._end_motion(RobotMode.kReflex)

    def _end_motion(self, mode: RobotMode) -> None:
        """The motion ends; the base brakes to rest."""
        self.motion = None
        self._target = (0.0, 0.0, 0.0)
        self.status.robot_mode = mode

    # -- TCP requests --------------------------------------------------------------------------
    def _admit(self, command_id: int, request) -> BaseMotion:
        spec = parse_move(request)
        if (spec.generator is not MoveMotionGeneratorMode.kCartesianVelocity
                or spec.use_async
                or spec.controller is MoveControllerMode.kExternalController):
            raise MoveRejected(MoveStatus.kCommandNotPossibleRejected,
                               f"a mobile base runs the Cartesian-velocity generator under "
                               f"an internal controller only, not {spec.generator.name} "
                               f"under {spec.controller.name}")
        if self.motion is not None or self.status.robot_mode is not RobotMode.kIdle:
            raise MoveRejected(MoveStatus.kCommandNotPossibleRejected,
                               f"base is in {self.status.robot_mode.name}")
        return BaseMotion(command_id, spec)

    def _set(self, command: Command, request) -> GetterSetterStatus:
        return GetterSetterStatus.kSuccess  # an arm's settings, which a base has no use for

    def request_recovery(self, command_id: int) -> list[bytes]:
        return [build_response(Command.AutomaticErrorRecovery, command_id, self._recover())]

    def _recover(self) -> AutomaticErrorRecoveryStatus:
        if self.status.robot_mode is RobotMode.kMove:
            return AutomaticErrorRecoveryStatus.kCommandNotPossibleRejected
        self.status.clear_errors()
        self.status.reflex_reason[:] = False
        self.status.robot_mode = RobotMode.kIdle
        return AutomaticErrorRecoveryStatus.kSuccess

    # -- the session's view --------------------------------------------------------------------
    def client_gone(self) -> None:
        """Its motion ends unanswered (nobody is left to answer) and the base brakes; under
        enforcement a running one ends in the reflex, as an arm's."""
        motion = self.motion
        if motion is not None and motion.running and self.enforce_comm_constraints:
            log.warning("the client left during its motion: %s", COMM_REFLEX)
            self._reflex(motion, COMM_REFLEX)
        elif motion is not None:
            self._end_motion(RobotMode.kIdle)
        self.status.take_replies()
