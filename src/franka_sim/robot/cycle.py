"""One arm's control cycle, sans-IO: release it, send its state, complete it.

This is the only place the sequence of a cycle is written; the server's cycle thread, the test
harness and the benchmarks all run it through `RobotCycle`:

1. `receive(command)` for each RobotCommand that arrived (an on-time answer closes the open
   cycle's command window at once);
2. `release()`: the core closes the window if still open and says what the drives do
   (`drive`), the physics steps once (with the Hand's finger command), the desired-side
   kinematics are taken at q_d when a generator sets it, and the core packs the RobotState
   (`publish`);
3. the caller sends the state;
4. `complete(released)`: the Hand advances on the new finger reading, the part of the physics
   step that no reading needed is done, the log-only limit checks run, and the replies the cycle
   produced (robot and Hand) are handed back to be written to TCP.

Work that a client does not wait for comes after the send, so a lockstep client gets its state
as early as possible; doing it later gives the same bits (physics/world.py, "Step
structure"). Time is the cycle number; no clock is read here.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from franka_sim.physics.backend import Backend, Measured
from franka_sim.robot.core import RobotCore
from franka_sim.robot.gripper import Gripper
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)


class Released:
    """A released cycle: its message_id, its RobotState bytes (None: packing failed, nothing
    to send), and the measurement it published. (A slotted class: a frozen dataclass costs
    ~1 µs more per cycle to build.)"""

    __slots__ = ("message_id", "state", "measured")

    def __init__(self, message_id: int, state: bytes | None, measured: Measured) -> None:
        self.message_id, self.state, self.measured = message_id, state, measured


@dataclass(frozen=True)
class Replies:
    """What a completed cycle leaves to write: robot replies, Hand replies, a GripperState."""

    robot: list[bytes]
    hand: list[bytes]
    hand_state: bytes | None

    def __bool__(self) -> bool:
        return bool(self.robot or self.hand or self.hand_state)

    def then(self, later: "Replies") -> "Replies":
        """These replies and a later cycle's, to go out together after the later state (its
        GripperState only: an earlier one would reach a client late)."""
        return Replies(self.robot + later.robot, self.hand + later.hand, later.hand_state)


NO_REPLIES = Replies([], [], None)  # what most cycles leave: shared, never written to


class PacerQuestions:
    """What a pacer asks of a robot's cycle, answered from its core (`self.core`): shared by an
    arm's RobotCycle and the mobile base's BaseCycle."""

    core: RobotCore

    @property
    def message_id(self) -> int:
        """The last published state's id."""
        return self.core.message_id

    @property
    def in_motion(self) -> bool:
        """A Move was admitted and has not ended (its first state may not be out yet)."""
        return self.core.motion is not None

    @property
    def lockstep_applies(self) -> bool:
        """The client answers every state now, so a lockstep pacer may wait for it."""
        return self.core.streams_commands

    @property
    def first_motion_state(self) -> bool:
        """The last state published is the one on which a motion's modes flipped."""
        return self.core.first_motion_state

    @property
    def client_driven(self) -> bool:
        """A client's motion runs (its commands, not the robot alone, decide what comes next)."""
        return self.core.motion_running


class RobotCycle(PacerQuestions):
    def __init__(self, core: RobotCore, physics: Backend, hand: Gripper | None = None, *,
                 hand_state_wanted=lambda: True) -> None:
        self.core = core
        self.physics = physics
        self.hand = hand
        self.hand_state_wanted = hand_state_wanted  # () -> bool: a Hand client takes states
        self._failures = 0
        self._measured = None  # the last step's measurement
        self._unchanged = False  # the last step handed back the one before (physics at rest)
        self._q_d = None  # the desired q of the cycle being released (None: no generator)
        self.completed_id = 0  # the last completed cycle's message_id
        self.recorder = None  # recording.Recorder, when the run is recorded

    # -- questions a pacer asks (and PacerQuestions') ------------------------------------------
    @property
    def busy(self) -> bool:
        """Something is under way that ends by itself: a motion, a recovery, a lost client's
        motion stopping, a Hand action."""
        return self.core.busy or self.hand_busy

    @property
    def hand_busy(self) -> bool:
        """A Hand action runs (a client may watch it and stop it)."""
        hand = self.hand
        return hand is not None and not hand.idle

    @property
    def at_rest(self) -> bool:
        """The next cycle would change nothing but message_id: no motion or recovery under way,
        the Hand idle, the robot's estimates steady, and the physics at rest (a step that can
        change nothing hands back the last measurement itself, physics "Rest")."""
        hand = self.hand
        return self._unchanged and self.core.settled and (hand is None or hand.idle)

    # -- the cycle -------------------------------------------------------------------------------
    def receive(self, command) -> bool:
        """A decoded RobotCommand; True if it answered the open cycle in time."""
        on_time = self.core.receive_command(command)
        if self.recorder is not None:
            self.recorder.command(command, on_time)
        return on_time

    def release(self) -> Released:
        self.physics.step(*self.drive())
        return self.publish()

    def drive(self) -> tuple:
        """The first half of `release`: the core closes the window and says what the drives
        do; (joint command, finger command or None) for the physics. (A world of several arms
        gives each arm its command, steps once, then has each cycle `publish`.)"""
        core = self.core
        joint_command = core.release_cycle()
        self._q_d = core.desired_q
        return joint_command, (None if self.hand is None else self.hand.command)

    def publish(self) -> Released:
        """The second half, once the physics stepped: the state from the new measurement."""
        core, physics, q_d = self.core, self.physics, self._q_d
        measured = physics.measure()
        self._unchanged = measured is self._measured
        self._measured = measured
        kinematics = None if q_d is None else physics.flange_pose_and_jacobian(q_d)
        try:
            state = core.publish(measured, kinematics)
        except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
            self._failed()
            state = None
        if self.recorder is not None:
            self.recorder.released(core.message_id)
        return Released(core.message_id, state, measured)

    def repeat(self) -> Released:
        """A cycle that leaves the world as it is: the last state again under the next
        message_id, nothing stepped (complete it as any other). At rest it is the cycle that
        stepping would give, bit for bit."""
        core = self.core
        state = core.republish()
        return Released(core.message_id, state, self._measured)

    def complete(self, released: Released) -> Replies:
        """After the state has left: the Hand, the rest of the step, the log-only checks. A
        cycle whose state could not be packed leaves its replies for the next one's state."""
        core, hand = self.core, self.hand
        robot_replies, hand_replies, hand_state = [], [], None
        if released.state is not None:
            robot_replies = core.take_replies()
            if hand is not None:
                try:
                    hand.advance(released.message_id, released.measured.fingers)
                    hand_replies = hand.take_replies()
                    if hand.state_due(released.message_id) and self.hand_state_wanted():
                        hand_state = hand.pack_state(released.message_id)
                except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
                    self._failed()
        self.physics.finish_step()
        core.run_deferred_checks()
        self.completed_id = released.message_id
        if robot_replies or hand_replies or hand_state is not None:
            return Replies(robot_replies, hand_replies, hand_state)
        return NO_REPLIES

    def _failed(self) -> None:
        self._failures += 1
        if worth_logging(self._failures):
            log.exception("cycle %d failed (%d so far)", self.core.message_id, self._failures)
