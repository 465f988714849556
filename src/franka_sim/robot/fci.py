"""What every robot behind an FCI endpoint does the same way, arm or mobile base (sans-IO).

libfranka drives an arm and a mobile base with one protocol, so one lifecycle serves both: the
clock (`message_id`, the last published state's id), the status and the replies it owes, the
TCP requests after Connect, and a Move from kMotionStarted to its end:

- the modes flip on the first state published after kMotionStarted (`_published`);
- each published state opens a command window; a command answering it in time closes it at
  once (so the next cycle's command is known before its deadline), and a release closes a
  window still open: `_close_window` is what the robot kind does with the command or the loss;
- a command while no motion runs is stray (counted, its first logged); one with a non-finite
  field is dropped, as the robot drops it;
- StopMove preempts the running Move (kPreempted), then answers kSuccess;
- until the motion's first command, lockstep may hold the world (`awaiting_first_command`,
  `republish`): libfranka reads a state or two before it answers one, and how many depends on
  the client's speed, not on the robot.

A robot kind (robot/arm_core.py: the arm; robot/base_core.py: the base) says what a Move may
be (`_admit`), what a closed window does (`_close_window`), what ending a motion leaves
(`_end_motion`), what its Set* requests change (`_set`), how it recovers
(`request_recovery`), what a client's leaving does (`client_gone`), and how it publishes.
"""

from __future__ import annotations

import logging

from franka_sim.protocol.codec import clipped_command, command_fields_out
from franka_sim.protocol.enums import (
    BaseStatus,
    Command,
    GetterSetterStatus,
    MoveStatus,
    RobotMode,
    StopMoveStatus,
)
from franka_sim.protocol.robot_messages import build_response
from franka_sim.robot.command_window import CommandWindow
from franka_sim.robot.events import (BRAKED, EXTRAPOLATED, GENERATED, HELD, MOTION_ENDED,
                                     NEWER_COMMAND, NO_ROBOT_EVENTS, RobotEvents)
from franka_sim.robot.motion import MoveRejected
from franka_sim.robot.status import RobotStatus
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

# The magnitude a command's value is taken at, at most, in its own unit (rad, rad/s, m, Nm...):
# far beyond anything an FR3 does, and far from where a cycle's differences overflow.
COMMAND_RANGE = 1e6

SETTERS = (Command.SetCollisionBehavior, Command.SetJointImpedance,
           Command.SetCartesianImpedance, Command.SetGuidingMode, Command.SetEEToK,
           Command.SetNEToEE, Command.SetLoad)


class FciRobot:
    """The shared lifecycle; a robot kind subclasses it (see the module docstring).

    `urdf`: what GetRobotModel answers; `events`: who hears the commands it takes and the
    cycles it loses (robot/events.py). Its log lines name no robot: in a world of several,
    which one is said by log_names.py."""

    def __init__(self, urdf: bytes, first_message_id: int = 1,
                 events: RobotEvents = NO_ROBOT_EVENTS) -> None:
        self.urdf = urdf
        self.events = events
        self.status = RobotStatus()
        self.window = CommandWindow()
        self.motion = None  # the running Move (a kind's motion: command_id, spec, running,
        #                    first_state, last_command), from its admission to its end
        self.message_id = first_message_id - 1  # id of the last published state
        self._window_closed = False  # the open cycle's command window was closed early
        self._stray_commands = 0  # this client's: its first one is logged
        self._beyond = 0  # commands with values beyond COMMAND_RANGE
        # How many states after its motion's first the client read before it answered one, at
        # the robot's last start (None: none yet): a lockstep clock's guide to the next. Kept
        # across connections (a program's, one after another, start alike), forgotten by a
        # reset: after it the robot is as freshly started, and a run the same as on a fresh one.
        self.start_reads: int | None = None

    # -- questions the server asks -----------------------------------------------------------
    @property
    def robot_mode(self) -> RobotMode:
        return self.status.robot_mode

    @property
    def motion_running(self) -> bool:
        return self.motion is not None and self.motion.running

    @property
    def streams_commands(self) -> bool:
        """A motion runs whose client answers every state (an async motion's does not), and
        the open state is not the motion's first: libfranka never answers the state on which
        the modes flip (its start-motion handshake reads it), so nothing waits for that one."""
        motion = self.motion
        return (motion is not None and motion.running and not motion.spec.use_async
                and motion.first_state != self.message_id)

    @property
    def answered_late(self) -> bool:
        """Its client's answer to the last closed cycle came, but late: it is there."""
        return self.window.late is not None

    @property
    def first_motion_state(self) -> bool:
        motion = self.motion
        return motion is not None and motion.first_state == self.message_id

    @property
    def awaiting_first_command(self) -> bool:
        """A streamed motion runs and its client has sent no command yet (none applied, none
        waiting in the window): nothing it decides has reached the robot."""
        motion = self.motion
        return (motion is not None and motion.running and not motion.spec.use_async
                and motion.last_command is None and not self.window.holds_command)

    @property
    def success_rate(self) -> float:
        return self.window.success_rate if self.motion_running else 0.0

    # -- the cycle -------------------------------------------------------------------------------
    def release_cycle(self):
        """Release the next cycle: close the open command window if an answer has not closed
        it already, then say what the robot's body does in the next step. A second call before
        the state is published only asks the body again."""
        if not self._window_closed:
            self._window_closed = True
            motion = self.motion
            if motion is not None and motion.running:
                before = motion.last_command
                self._close_window(motion)
                if self.window.consecutive_lost:  # this cycle's answer did not come in time
                    self.events.lost(self.message_id, self._filled(motion, before))
            else:
                self._idle_release()
        return self._drive()

    def _filled(self, motion, before) -> str:
        """What the robot made of a lost cycle, as its motion shows once the window closed
        (robot/events.py LOST_FILLS); `before`: its last command before the close."""
        if self.motion is not motion:
            return MOTION_ENDED
        if motion.last_command is not before:
            return NEWER_COMMAND
        if motion.braking:
            return BRAKED
        if motion.spec.use_async:
            return GENERATED
        if motion.last_command is None:
            return HELD
        return EXTRAPOLATED

    def _published(self):
        """The clock advances to a newly published state: a Move's modes flip on the first
        one, and each opens its command window. The running motion (None: none)."""
        self.message_id += 1
        self._window_closed = False
        motion = self.motion
        if motion is not None:
            if not motion.running:
                motion.running = True  # the modes flip on the first state after kMotionStarted
                motion.first_state = self.message_id
                self.status.motion_started()
            self.window.opened(self.message_id)
        return motion

    def skip(self, cycles: int) -> None:
        """The clock moves on `cycles` ids with no state: lockstep rounds an idle gap up to
        whole IDLE_QUANTUM cycles (server/clock.py). Only while nothing is under way, so no
        motion's window opens for them."""
        self.message_id += cycles

    def published(self) -> bytes:
        """The state last published, under its own message_id: what a client connecting now
        would read first (the web view's, while the clock is paused)."""
        return self.publisher.restamp(self.message_id)

    def republish(self) -> bytes:
        """The last state again as the next cycle's, nothing stepped or estimated: a cycle of
        a world left as it was (lockstep's idle time, or a motion awaiting its client's first
        command: its window opens for the new id)."""
        self.message_id += 1
        self._window_closed = False
        motion = self.motion
        if motion is not None and motion.running:
            self.window.opened(self.message_id)
        return self.publisher.restamp(self.message_id)

    # -- UDP commands ----------------------------------------------------------------------------
    def receive_command(self, command) -> bool:
        """A RobotCommand datagram from the client. True if it answered the open cycle in time."""
        on_time = self._take_command(command)
        self.events.command(command, on_time)
        return on_time

    def _take_command(self, command) -> bool:
        motion = self.motion
        message_id = int(command["message_id"])
        if motion is None or not motion.running:
            self._stray_commands += 1
            if worth_logging(self._stray_commands):
                log.info("RobotCommand for message_id %d ignored: no motion is running "
                         "(%d so far)", message_id, self._stray_commands)
            return False
        bad, beyond = command_fields_out(command, COMMAND_RANGE)
        if bad:
            log.warning("RobotCommand for message_id %d dropped: non-finite %s",
                        message_id, ", ".join(bad))
            return False
        if beyond:
            # Limits only logged apply what comes: a value no FR3 comes near is taken at the
            # range's edge, so every signal derived from it (rates, torques, kinematics) stays
            # finite. (Enforced, the checks refuse it as any other value out of the limits.)
            self._beyond += 1
            if worth_logging(self._beyond):
                log.warning("RobotCommand for message_id %d: %s beyond ±%g taken as ±%g "
                            "(%d so far)", message_id, ", ".join(beyond),
                            COMMAND_RANGE, COMMAND_RANGE, self._beyond)
            command = clipped_command(command, COMMAND_RANGE)
        if motion.last_command is None and self.awaiting_first_command \
                and motion.first_state is not None:
            reads = message_id - motion.first_state  # (an id before the start's: unknown)
            self.start_reads = reads if reads >= 0 else None
        on_time = self.window.take(message_id, command)
        if on_time and not self._window_closed:
            # The answer is in: the window closes now, so the next cycle's command is known
            # before its deadline (the server can release it without asking again).
            self._window_closed = True
            self._close_window(motion)
        return on_time

    # -- TCP requests ----------------------------------------------------------------------------
    def handle(self, command: Command, command_id: int, request) -> list[bytes]:
        """A request after Connect (robot/session.py hands them here); the replies due now."""
        if command is Command.GetRobotModel:
            return [build_response(command, command_id, BaseStatus.kSuccess, urdf=self.urdf)]
        if command in SETTERS:
            return [build_response(command, command_id, self._setter(command, request))]
        if command is Command.Move:
            return self.request_move(command_id, request)
        if command is Command.StopMove:
            return self.request_stop(command_id)
        if command is Command.AutomaticErrorRecovery:
            return self.request_recovery(command_id)
        raise AssertionError(f"unhandled command {command!r}")  # the framing knows all 12

    def request_move(self, command_id: int, request) -> list[bytes]:
        try:
            motion = self._admit(command_id, request)
        except MoveRejected as exc:
            log.warning("Move rejected (%s): %s", exc.status.name, exc)
            return [build_response(Command.Move, command_id, exc.status)]
        self.motion = motion
        self.window = CommandWindow()
        self._started(motion)
        return [build_response(Command.Move, command_id, MoveStatus.kMotionStarted)]

    def request_stop(self, command_id: int) -> list[bytes]:
        replies = []
        if self.motion is not None:
            replies.append(build_response(Command.Move, self.motion.command_id,
                                          MoveStatus.kPreempted))
            self._end_motion(RobotMode.kIdle)
        replies.append(build_response(Command.StopMove, command_id, StopMoveStatus.kSuccess))
        return replies

    def _setter(self, command: Command, request) -> GetterSetterStatus:
        if self.robot_mode is RobotMode.kMove:
            # Parameters are latched when a motion starts; the robot refuses changes mid-motion.
            log.info("%s refused: a motion is running", command.name)
            return GetterSetterStatus.kCommandNotPossibleRejected
        return self._set(command, request)

    # -- the session's view ----------------------------------------------------------------------
    def client_connected(self) -> None:
        """A client completed Connect; states now stream to it (and its first stray command
        is logged, whatever earlier clients sent)."""
        self._stray_commands = 0

    def take_replies(self) -> list[bytes]:
        """TCP replies the robot produced on its own (a Move's final status), in order."""
        return self.status.take_replies()

    # -- what a robot kind says ------------------------------------------------------------------
    def _admit(self, command_id: int, request):
        """The motion a Move starts (MoveRejected with the robot's status if it may not)."""
        raise NotImplementedError

    def _started(self, motion) -> None:
        """A Move was admitted (its first state is still to come)."""

    def _close_window(self, motion) -> None:
        """The open cycle's window ends: apply the command that answered it, or fill the
        cycle as the robot does without one."""
        raise NotImplementedError

    def _idle_release(self) -> None:
        """A cycle released with no motion running."""

    def _drive(self):
        """What the robot's body does in the next step."""
        raise NotImplementedError

    def _end_motion(self, mode: RobotMode) -> None:
        raise NotImplementedError

    def _set(self, command: Command, request) -> GetterSetterStatus:
        raise NotImplementedError

    def request_recovery(self, command_id: int) -> list[bytes]:
        raise NotImplementedError
