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
  is heard again); a twist with vz, wx or wy is a reflex
  (cartesian_motion_generator_velocity_limits_violation), recovered by
  AutomaticErrorRecovery;
- a finished motion, StopMove or a client gone leaves the base braking to rest.
The drive itself (limits, pose, swerve modules) is robot/swerve.py; the state, base_state.py.
"""

from __future__ import annotations

import logging

from franka_sim.protocol.codec import non_finite_command_fields
from franka_sim.protocol.enums import (AutomaticErrorRecoveryStatus, BaseStatus, Command,
                                       GetterSetterStatus, MoveControllerMode,
                                       MoveMotionGeneratorMode, MoveStatus, RobotMode,
                                       StopMoveStatus)
from franka_sim.protocol.robot_messages import build_response
from franka_sim.robot.base_state import BaseStatePublisher
from franka_sim.robot.command_window import CommandWindow
from franka_sim.robot.motion import MAX_EXTRAPOLATED_CYCLES, MoveRejected, MoveSpec, parse_move
from franka_sim.robot.status import RobotStatus
from franka_sim.robot.swerve import SwerveDrive
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

PLANAR_TOLERANCE = 1e-6  # m/s, rad/s: what vz, wx and wy may be without a reflex
PLANAR_REFLEX = "cartesian_motion_generator_velocity_limits_violation"


class BaseMotion:
    """A running base motion: its Move's id and modes, and the client's last twist."""

    __slots__ = ("command_id", "spec", "running", "first_state", "twist_c")

    def __init__(self, command_id: int, spec: MoveSpec) -> None:
        self.command_id, self.spec = command_id, spec
        self.running = False  # the modes flip on the first state after kMotionStarted
        self.first_state = -1
        self.twist_c: tuple | None = None  # None until the client's first command


class BaseCore:
    def __init__(self, urdf: bytes, first_message_id: int = 1) -> None:
        self.urdf = urdf
        self.status = RobotStatus()
        self.drive = SwerveDrive()
        self.publisher = BaseStatePublisher()
        self.window = CommandWindow()
        self.motion: BaseMotion | None = None
        self.message_id = first_message_id - 1
        self._target = (0.0, 0.0, 0.0)  # the body twist the drive follows
        self._stray_commands = 0

    # -- questions the server asks -------------------------------------------------------------
    @property
    def robot_mode(self) -> RobotMode:
        return self.status.robot_mode

    @property
    def motion_running(self) -> bool:
        return self.motion is not None and self.motion.running

    @property
    def streams_commands(self) -> bool:
        motion = self.motion
        return motion is not None and motion.running and motion.first_state != self.message_id

    @property
    def first_motion_state(self) -> bool:
        motion = self.motion
        return motion is not None and motion.first_state == self.message_id

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
    def release_cycle(self) -> tuple[float, float, float]:
        """Close the open command window, move the base one cycle; its planar pose (x, y, yaw)."""
        motion = self.motion
        if motion is not None and motion.running:
            self._close_window(motion)
        drive = self.drive
        drive.step(*self._target)
        return drive.x, drive.y, drive.yaw

    def publish(self) -> bytes:
        self.message_id += 1
        motion = self.motion
        if motion is not None:
            if not motion.running:
                motion.running = True
                motion.first_state = self.message_id
                self.status.motion_started()
            self.window.opened(self.message_id)
            return self.publisher.pack(self.message_id, self.drive, motion.twist_c,
                                       self.status.robot_mode, self.window.success_rate,
                                       motion.spec.state_modes, self.status)
        return self.publisher.pack(self.message_id, self.drive, None, self.status.robot_mode,
                                   0.0, None, self.status)

    def republish(self) -> bytes:
        self.message_id += 1
        return self.publisher.restamp(self.message_id)

    def _close_window(self, motion: BaseMotion) -> None:
        command = self.window.close()
        if command is None:
            if self.window.consecutive_lost >= MAX_EXTRAPOLATED_CYCLES:
                if self.window.consecutive_lost == MAX_EXTRAPOLATED_CYCLES:
                    log.warning("base client silent for %d cycles: braking to rest",
                                MAX_EXTRAPOLATED_CYCLES)
                self._target = (0.0, 0.0, 0.0)
            return
        twist = tuple(float(v) for v in command["O_dP_EE_c"])
        motion.twist_c = twist
        vx, vy, vz, wx, wy, wz = twist
        if max(abs(vz), abs(wx), abs(wy)) > PLANAR_TOLERANCE:
            log.warning("base twist has vz/wx/wy %.3g/%.3g/%.3g: a base moves in the plane "
                        "only (%s)", vz, wx, wy, PLANAR_REFLEX)
            self.status.latch([PLANAR_REFLEX])
            self._end_motion(MoveStatus.kReflexAborted, RobotMode.kReflex)
            return
        self._target = (vx, vy, wz)
        if bool(command["motion_generation_finished"]):
            self._end_motion(MoveStatus.kSuccess, RobotMode.kIdle)

    def _end_motion(self, answer: MoveStatus | None, mode: RobotMode) -> None:
        """The motion ends (answered `answer`, None: not at all); the base brakes to rest."""
        if answer is not None:
            self.status.answer_move(self.motion.command_id, answer)
        self.motion = None
        self._target = (0.0, 0.0, 0.0)
        self.status.robot_mode = mode

    # -- UDP commands --------------------------------------------------------------------------
    def receive_command(self, command) -> bool:
        """A RobotCommand datagram; True if it answered the open cycle in time."""
        if not self.motion_running:
            self._stray_commands += 1
            if worth_logging(self._stray_commands):
                log.info("base RobotCommand for message_id %d ignored: no motion is running "
                         "(%d so far)", int(command["message_id"]), self._stray_commands)
            return False
        if non_finite_command_fields(command):
            log.warning("base RobotCommand for message_id %d dropped: non-finite fields",
                        int(command["message_id"]))
            return False
        return self.window.receive(int(command["message_id"]), command)

    # -- TCP requests --------------------------------------------------------------------------
    def handle(self, command: Command, command_id: int, request) -> list[bytes]:
        """A request after Connect (robot/session.py hands them here); the replies due now."""
        if command is Command.GetRobotModel:
            return [build_response(command, command_id, BaseStatus.kSuccess, urdf=self.urdf)]
        if command is Command.Move:
            return [build_response(command, command_id, self._move(command_id, request))]
        if command is Command.StopMove:
            replies = []
            if self.motion is not None:
                replies.append(build_response(Command.Move, self.motion.command_id,
                                              MoveStatus.kPreempted))
                self._end_motion(None, RobotMode.kIdle)
            return replies + [build_response(command, command_id, StopMoveStatus.kSuccess)]
        if command is Command.AutomaticErrorRecovery:
            return [build_response(command, command_id, self._recover())]
        # The Set* requests: an arm's settings, which a base has no use for.
        return [build_response(command, command_id, GetterSetterStatus.kSuccess)]

    def _move(self, command_id: int, request) -> MoveStatus:
        try:
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
        except MoveRejected as exc:
            log.warning("base Move rejected (%s): %s", exc.status.name, exc)
            return exc.status
        self.motion = BaseMotion(command_id, spec)
        self.window = CommandWindow()
        return MoveStatus.kMotionStarted

    def _recover(self) -> AutomaticErrorRecoveryStatus:
        if self.status.robot_mode is RobotMode.kMove:
            return AutomaticErrorRecoveryStatus.kCommandNotPossibleRejected
        self.status.clear_errors()
        self.status.reflex_reason[:] = False
        self.status.robot_mode = RobotMode.kIdle
        return AutomaticErrorRecoveryStatus.kSuccess

    # -- the session's view --------------------------------------------------------------------
    def client_connected(self) -> None:
        self._stray_commands = 0

    def client_gone(self) -> None:
        """Its motion ends unanswered (nobody is left to answer) and the base brakes."""
        if self.motion is not None:
            self._end_motion(None, RobotMode.kIdle)
        self.status.take_replies()

    def take_replies(self) -> list[bytes]:
        return self.status.take_replies()
