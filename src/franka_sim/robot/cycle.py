"""The contract of a control cycle, sans-IO: what the server's clock runs, and what each robot
of a world contributes to it.

A world cycle (`Cycle`, robot/world_cycle.py) is what the cycle thread runs, for a world of one
arm as for several arms and a mobile base. Each robot has its part (`RobotPart`: an arm's
robot/arm_cycle.py, the base's robot/base_cycle.py), run in a fixed order around the world's
one physics step:

1. `receive(robot, command)` for each RobotCommand that arrived, tagged with the robot's index
   (an on-time answer closes that robot's open command window at once);
2. `release()`: every robot's part says what its body does in the next step (`drive`), the world
   steps once, every part publishes its state (`publish`); or `repeat()`: the world left as it
   is, each robot's last state again under the next message_id; or `hold()`: the same while a
   motion awaits its client's first command (None when it cannot: step instead);
3. the caller sends the states;
4. `complete(released)`: the part of the step no client waits for, each robot's tools and
   replies, handed back to be written to TCP.

Time is the cycle number; nothing here reads a clock. Whoever runs a cycle asks it the
questions in `PacerQuestions` to decide when the next one goes (server/clock.py).
"""

from __future__ import annotations

from typing import Protocol

from franka_sim.physics.backend import Measured


class Released:
    """A released cycle of one robot: its message_id, its RobotState bytes (None: packing
    failed, nothing to send), and the measurement it published. (A slotted class: a frozen
    dataclass costs ~1 µs more per cycle to build.)"""

    __slots__ = ("message_id", "state", "measured")

    def __init__(self, message_id: int, state: bytes | None, measured: Measured | None) -> None:
        self.message_id, self.state, self.measured = message_id, state, measured


class Replies:
    """What one robot's completed cycle leaves to write: the robot's TCP replies, and each of
    its tools' (replies, state or None), in the order of its tools."""

    __slots__ = ("robot", "tools")

    def __init__(self, robot: list[bytes], tools: tuple = ()) -> None:
        self.robot, self.tools = robot, tools

    def __bool__(self) -> bool:
        return bool(self.robot) or any(replies or state is not None
                                       for replies, state in self.tools)

    def then(self, later: "Replies") -> "Replies":
        """These replies and a later cycle's, to go out together after the later state (a
        tool's later state only: an earlier one would reach a client late)."""
        if not self.tools:
            tools = later.tools
        elif not later.tools:
            tools = tuple((replies, None) for replies, _ in self.tools)
        else:
            tools = tuple((replies + later_replies, later_state) for (replies, _), (
                later_replies, later_state) in zip(self.tools, later.tools))
        return Replies(self.robot + later.robot, tools)


NO_REPLIES = Replies([])  # what most cycles leave: shared, never written to


class PacerQuestions:
    """What a clock asks of one robot's cycle, answered from its core (`self.core`, an
    robot/fci.py FciRobot): shared by every robot kind's part."""

    core = None

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
        """The client answers every state now, so a lockstep clock may wait for it."""
        return self.core.streams_commands

    @property
    def first_motion_state(self) -> bool:
        """The last state published is the one on which a motion's modes flipped."""
        return self.core.first_motion_state

    @property
    def client_driven(self) -> bool:
        """A client's motion runs (its commands, not the robot alone, decide what comes next)."""
        return self.core.motion_running

    @property
    def awaiting_first_command(self) -> bool:
        """A streamed motion runs whose client has sent no command yet."""
        return self.core.awaiting_first_command


class RobotPart(Protocol):
    """One robot's part of a world cycle (an arm's, the base's)."""

    core: object  # its robot/fci.py FciRobot
    completed_id: int  # the last completed cycle's message_id

    @property
    def busy(self) -> bool:
        """Something is under way that ends by itself (a motion, a recovery, a tool's action)."""

    @property
    def tool_busy(self) -> bool:
        """One of its tools runs an action a client may watch (and stop)."""

    @property
    def at_rest(self) -> bool:
        """The next cycle would change nothing of this robot but message_id."""

    def receive(self, command) -> bool:
        """A decoded RobotCommand; True if it answered the open cycle in time."""

    def drive(self) -> None:
        """Say what its body does in the world's next step (closes the command window)."""

    def publish(self) -> Released:
        """Once the world stepped: its state from the new measurement."""

    def repeat(self) -> Released:
        """Its last state again under the next message_id, nothing stepped."""

    def skip(self, cycles: int) -> None:
        """Its clock (and its tools') moves on `cycles` ids, no state, nothing stepped."""

    def complete(self, released: Released) -> Replies:
        """After the state has left: its tools, the rest of the step, its replies."""


class Cycle(Protocol):
    """A world's control cycle (robot/world_cycle.py), as a clock runs it."""

    message_id: int
    in_motion: bool
    lockstep_applies: bool
    first_motion_state: bool
    client_driven: bool
    busy: bool
    tool_busy: bool
    at_rest: bool
    holds_start: bool
    starting: tuple[int, int | None] | None  # (robot, its client's reads at its last start)
    waits_for: frozenset[int]

    def receive(self, robot: int, command) -> bool:
        """True when it was the last answer the open state waited for."""

    def release(self): ...

    def repeat(self): ...

    def hold(self):
        """repeat() while a motion awaits its client's first command; None: release instead."""

    def skip(self, cycles: int) -> None:
        """The clock moves on `cycles` ids, no state sent, nothing stepped (idle only)."""

    def rewind(self, message_id: int) -> None:
        """Every robot's clock back to `message_id`: a cycle released ahead was not sent."""

    def complete(self, released): ...
