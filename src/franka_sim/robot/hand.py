"""The Franka Hand behind gripper protocol v3: a state machine clocked by the robot's cycle number,
the arm's tool device (robot/tool.py; its actions: robot/hand_actions.py).

No sockets, threads or wall time. Decoded requests come in through `request()`; after every
physics step the arm's cycle calls `advance(cycle, fingers)` with the finger sensors. The hand
answers Homing, Move and Grasp when the action completes (libfranka blocks until then), says
what the finger drive does next (`command`), and packs a GripperState whenever
`state_due(cycle)`.

Figures and choices (docs/figures.md, "The Franka Hand", where sourced; ours otherwise):
- GripperState at 10 Hz, every 100th cycle: Franka's maintainers put the ~10 Hz read rate down to
  the hand's internals, franky measured a new state every ~0.1 s, franka_ros2 says "maximally
  15 Hz". Its time is the robot's cycle number (ms), the clock RobotState.time counts too.
- Speeds are of the opening (m of width per s), at most 0.1 m/s (the clients' maximum and default);
  faster requests are clamped. Move and Grasp ramp the opening at constant speed, so a Move takes
  |Δwidth|/speed, to the cycle, and ends when the opening is within 0.5 mm of its goal.
- Homing closes, then opens to the mechanical stops, both at 0.1 m/s, and measures max_width
  there. Before any homing, max_width is the datasheet's 0.08 m. Once homed, the Hand holds its
  fingers STOP_CLEARANCE inside that opening, never against the stops: max_width is read while
  pressing them, and they give a few µm under that force.
- Grasp closes at `speed` pushing with at most `force` per finger. When the fingers stop on
  something (they trail the closing ramp by 2 mm) or the ramp has closed them, the hand squeezes
  with `force` and, 50 ms later, tests width − ε_inner < d < width + ε_outer on the opening d:
  kSuccess and is_grasped (it keeps squeezing), else kUnsuccessful and it stops squeezing where
  it is (franka_ros#16: it does not keep squeezing a wrong width).
- A Move that cannot reach its goal (something in the way) answers kUnsuccessful 0.5 s after its
  ramp ended, and the fingers stay where they stopped.
- Bad arguments (non-finite, width outside [0, max_width], speed below 1 mm/s, force ≤ 0,
  ε < 0) answer kFail, libfranka's CommandException. Every request is answered, within the time
  its ramp takes plus at most a few seconds.
- Stop ends a running action (which answers kAborted) and releases a grasp; a new action preempts
  a running one the same way.
"""

from __future__ import annotations

import logging

from franka_sim.physics.fingers import FingerCommand, FingerState
from franka_sim.protocol.codec import GripperStateBuffer
from franka_sim.protocol.enums import GripperCommand, GripperStatus
from franka_sim.protocol.gripper_messages import build_gripper_response
from franka_sim.robot.hand_actions import (MAX_FORCE, MAX_SPEED, MIN_SPEED, NOMINAL_MAX_WIDTH,
                                           STATE_PERIOD, STOP_CLEARANCE, TEMPERATURE, Grasp,
                                           GraspArgs, Homing, Move, finite)

log = logging.getLogger(__name__)

WIDTH_DECIMALS = 9  # the reported width's resolution: 1 nm

__all__ = ["MAX_SPEED", "NOMINAL_MAX_WIDTH", "STATE_PERIOD", "Hand"]


class Hand:
    """The Hand: its calibration, the running action, the grasp, and what the fingers do next
    (a tool device: robot/tool.py)."""

    kind = "hand"

    def __init__(self, *, state_period: int = STATE_PERIOD,
                 max_width: float = NOMINAL_MAX_WIDTH) -> None:
        self.state_period = state_period
        self.max_width = max_width
        self.width = max_width  # last measured opening (the fingers start open)
        self._widest_hold = max_width  # no hold opens wider (homing: just inside its stops)
        self.is_grasped = False
        self.cycle = 0  # last advanced cycle
        self._action: Move | Grasp | Homing | None = None
        self._grasp: GraspArgs | None = None  # the object held, while squeezing it
        self._idle: FingerCommand | None = None  # None: the drive keeps what it had
        self._replies: list[bytes] = []
        self._buffer = GripperStateBuffer()
        self._buffer.temperature[...] = TEMPERATURE

    # -- the cycle ---------------------------------------------------------------------------
    @property
    def idle(self) -> bool:
        """No action runs (a held grasp is no action: nothing in it moves on by itself)."""
        return self._action is None

    @property
    def command(self) -> FingerCommand | None:
        """The finger drive's command for the next cycle (None: unchanged)."""
        if self._action is not None:
            return self._action.command(self.cycle + 1)
        if self._grasp is not None:
            return FingerCommand(0.0, 0.0, self._grasp.force)
        return self._idle

    def advance(self, cycle: int, fingers: FingerState | None) -> None:
        """Cycle `cycle` was stepped and these are the fingers after it."""
        self.cycle = cycle
        if fingers is None:
            return
        self.width = max(0.0, fingers.width)
        if self._grasp is not None:
            self.is_grasped = self._grasp.holds(fingers.width)
        action = self._action
        if action is None:
            return
        status = action.update(cycle, fingers)
        if status is None:
            return
        self._action = None
        if action.command_id is not None:  # (None: the Desk's homing, which no client awaits)
            self._replies.append(build_gripper_response(action.kind, action.command_id, status))
        if status is GripperStatus.kSuccess and isinstance(action, Grasp):
            self._grasp = action.args
            self.is_grasped = True
            return
        if isinstance(action, Homing) and action.max_width is not None:
            self.max_width = action.max_width
            self._widest_hold = action.max_width - STOP_CLEARANCE
        if isinstance(action, Move) and status is GripperStatus.kSuccess:
            self._hold(action.ramp.goal)
        else:  # stay where the fingers stopped (a missed grasp stops squeezing)
            self._hold(fingers.width)

    def skip(self, cycles: int) -> None:
        self.cycle += cycles
        if self._action is not None:  # requested in the idle gap, not yet begun
            self._action.ramp.first += cycles

    def state_due(self, cycle: int) -> bool:
        return cycle % self.state_period == 0

    def pack_state(self, cycle: int) -> bytes:
        """The 23-byte GripperState for `cycle`."""
        s = self._buffer
        s.message_id[...] = cycle & 0xFFFFFFFF
        # To the nanometre: a physics settling onto 0 or onto a hold reads 1e-49 m, or 6e-17 m
        # past max_width, which no encoder would report.
        s.width[...] = round(self.width, WIDTH_DECIMALS)
        s.max_width[...] = self.max_width
        s.is_grasped[...] = self.is_grasped
        return s.pack()

    def take_replies(self) -> list[bytes]:
        """Answers to actions that completed, in order."""
        replies, self._replies = self._replies, []
        return replies

    # -- requests ----------------------------------------------------------------------------
    def request(self, command: GripperCommand, command_id: int, request) -> list[bytes]:
        """A decoded Homing/Move/Grasp/Stop; returns what is answered at once."""
        if command is GripperCommand.Stop:
            return self._stop(command_id)
        if command is GripperCommand.Homing:
            return self._start(Homing(command_id, self.cycle + 1, self.width))
        if command is GripperCommand.Move:
            width, speed = float(request.width), float(request.speed)
            problem = self._check_width(width) or self._check_speed(speed)
            if problem:
                return self._fail(command, command_id, problem)
            return self._start(Move(command_id, self.cycle + 1, self.width, width,
                                     min(speed, MAX_SPEED)))
        if command is GripperCommand.Grasp:
            args = GraspArgs(float(request.width), float(request.epsilon_inner),
                              float(request.epsilon_outer), float(request.speed),
                              float(request.force))
            problem = (self._check_width(args.width) or self._check_speed(args.speed)
                       or self._check_grasp(args))
            if problem:
                return self._fail(command, command_id, problem)
            args = GraspArgs(args.width, args.epsilon_inner, args.epsilon_outer,
                              min(args.speed, MAX_SPEED), min(args.force, MAX_FORCE))
            return self._start(Grasp(command_id, self.cycle + 1, self.width, args))
        raise AssertionError(f"unhandled gripper command {command!r}")  # Connect: the session's

    def home(self) -> bool:
        """A homing no client asked for (the Desk's, someone at the robot): started unless an
        action is under way (False), whose client's answer it would otherwise cut short."""
        if self._action is not None:
            return False
        self._start(Homing(None, self.cycle + 1, self.width))
        return True

    @property
    def busy(self) -> bool:
        """An action (Homing, Move, Grasp) is under way: its client waits for the answer."""
        return self._action is not None

    def reset(self, reading: FingerState) -> None:
        """As a Hand starts: not homed, holding nothing, the fingers where `reading` has them,
        at rest (the physics put them there). Only while no action is under way."""
        if self._action is not None:
            raise ValueError("a gripper action is under way")
        self.max_width = self._widest_hold = NOMINAL_MAX_WIDTH
        self.width = reading.width
        self.is_grasped = False
        self._grasp = None
        self._idle = None  # the drive keeps the command the physics was reset with
        self._replies.clear()

    def client_gone(self) -> None:
        """The client closed TCP: nobody waits for answers; the hand stops where it is.

        A grasp survives (the hand keeps holding what it holds, as a real one does)."""
        self._replies.clear()
        if self._action is not None:
            self._action = None
            self._hold(self.width)

    # -- transitions -------------------------------------------------------------------------
    def _start(self, action) -> list[bytes]:
        replies = self._abort_running()
        self._grasp = None
        self.is_grasped = False
        self._action = action
        return replies

    def _stop(self, command_id: int) -> list[bytes]:
        replies = self._abort_running()
        self._grasp = None
        self.is_grasped = False
        self._hold(self.width)
        replies.append(build_gripper_response(GripperCommand.Stop, command_id,
                                              GripperStatus.kSuccess))
        return replies

    def _abort_running(self) -> list[bytes]:
        action, self._action = self._action, None
        if action is None or action.command_id is None:  # (the Desk's homing: nobody awaits it)
            return []
        return [build_gripper_response(action.kind, action.command_id, GripperStatus.kAborted)]

    def _hold(self, width: float) -> None:
        self._idle = FingerCommand(min(max(0.0, width), self._widest_hold), 0.0, MAX_FORCE)

    # -- argument checks: a reason string when the hand refuses ---------------------------------
    def _fail(self, command: GripperCommand, command_id: int, problem: str) -> list[bytes]:
        log.warning("gripper %s refused (kFail): %s", command.name, problem)
        return [build_gripper_response(command, command_id, GripperStatus.kFail)]

    def _check_width(self, width: float) -> str:
        if not finite(width):
            return f"width {width} is not finite"
        if not 0.0 <= width <= self.max_width:
            return f"width {width} m outside [0, {self.max_width:.4f}] m"
        return ""

    @staticmethod
    def _check_speed(speed: float) -> str:
        if not finite(speed) or speed < MIN_SPEED:
            return f"speed {speed} m/s is not a number of at least {MIN_SPEED} m/s"
        return ""

    @staticmethod
    def _check_grasp(args: GraspArgs) -> str:
        if not finite(args.force) or args.force <= 0.0:
            return f"force {args.force} N is not a positive number"
        if not finite(args.epsilon_inner, args.epsilon_outer) \
                or args.epsilon_inner < 0.0 or args.epsilon_outer < 0.0:
            return f"epsilons {args.epsilon_inner}, {args.epsilon_outer} m are not ≥ 0"
        return ""
