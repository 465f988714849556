"""A world's control cycle, sans-IO: every robot's part around one physics step.

A world holds one arm, several arms, or arms on a mobile base; each robot is a whole robot (its
own core, tools, commands and replies: robot/arm_cycle.py, robot/base_cycle.py), and what they
share is the world, so they share its clock. A world cycle has every robot's part say what its
body does (`drive`), steps the world once, and has every part publish its state (`publish`): all
states of a cycle carry the same message_id and show the same instant, so contact between two
arms is seen by both in the same cycle. A world of one arm is the same cycle with one part.

`WorldCycle` answers a clock's questions as one robot would (server/clock.py): a client motion
anywhere makes the world client-driven, and in lockstep the next cycle waits for the answers of
every robot whose client streams commands (`waits_for`: the one answer to "whom does lockstep
wait for", which the network faults ask too). A robot whose motion has just started (libfranka
never answers that first state) is not waited for while another streams; alone, it sets the
pace as a lone robot's would.
"""

from __future__ import annotations

from operator import attrgetter, methodcaller
from typing import Callable, Sequence

from franka_sim.robot.cycle import NO_REPLIES, Released, Replies, RobotPart
from franka_sim.robot.events import NO_WORLD_EVENTS, WorldEvents


class WorldReleased:
    """A released world cycle: its message_id, one Released per robot, and their states (one
    per robot, None where packing failed) for the sender."""

    __slots__ = ("message_id", "robots", "states")

    def __init__(self, robots: tuple[Released, ...]) -> None:
        self.robots = robots
        self.message_id = robots[0].message_id
        self.states = tuple(map(_state, robots))


_state = attrgetter("state")


class WorldReplies:
    """What a completed world cycle leaves to write, one Replies per robot (by index)."""

    __slots__ = ("robots",)

    def __init__(self, robots: tuple[Replies, ...]) -> None:
        self.robots = robots

    def __bool__(self) -> bool:
        return any(self.robots)

    def then(self, later: "WorldReplies") -> "WorldReplies":
        return WorldReplies(tuple(a.then(b) for a, b in zip(self.robots, later.robots)))


_publish, _repeat = methodcaller("publish"), methodcaller("repeat")


class WorldCycle:
    """The robots' parts (in a fixed order: a world cycle runs them in it, so the same command
    streams give the same bits), `step`, the world's one physics step, and `events`, who hears
    each cycle released or repeated (robot/events.py)."""

    def __init__(self, parts: Sequence[RobotPart], step: Callable[[], None],
                 events: WorldEvents = NO_WORLD_EVENTS) -> None:
        if not parts:
            raise ValueError("a world cycle needs a robot")
        self.parts = tuple(parts)
        self.step = step
        self.events = events
        # Whom the open state waits for (lockstep), by robot index: `waits_for` as released,
        # `_awaited` those of them that have not answered yet.
        self.waits_for: frozenset[int] = frozenset()
        self._awaited: set[int] = set()
        self.nothing = WorldReplies(tuple(NO_REPLIES for _ in self.parts))

    # -- questions a clock asks, about the world (loops, not generators: asked every tick) -----
    @property
    def message_id(self) -> int:
        return self.parts[0].message_id

    @property
    def in_motion(self) -> bool:
        for part in self.parts:
            if part.core.motion is not None:
                return True
        return False

    @property
    def lockstep_applies(self) -> bool:
        for part in self.parts:
            core = part.core
            if core.streams_commands:
                return True
        return False

    @property
    def first_motion_state(self) -> bool:
        """A motion's first state is out and no other robot's client streams: the next goes one
        period after it, as for a lone robot."""
        first = False
        for part in self.parts:
            core = part.core
            if core.streams_commands:
                return False
            first = first or core.first_motion_state
        return first

    @property
    def client_driven(self) -> bool:
        for part in self.parts:
            if part.core.motion_running:
                return True
        return False

    @property
    def busy(self) -> bool:
        for part in self.parts:
            if part.busy:
                return True
        return False

    @property
    def tool_busy(self) -> bool:
        for part in self.parts:
            if part.tool_busy:
                return True
        return False

    @property
    def at_rest(self) -> bool:
        for part in self.parts:
            if not part.at_rest:
                return False
        return True

    @property
    def holds_start(self) -> bool:
        """Some robot's motion awaits its client's first command and nothing else is under
        way: lockstep may hold the world until it comes (`hold`)."""
        waiting = False
        for part in self.parts:
            if part.core.awaiting_first_command and not part.tool_busy:
                waiting = True
            elif part.busy:
                return False
        return waiting

    @property
    def starting(self) -> tuple[int, int | None] | None:
        """The one robot whose motion is starting (its first state out, or its client's first
        command awaited) and how many states after the first its client read before it
        answered one at its last start (robot/fci.py `start_reads`); None: none, or several."""
        found = None
        for i, part in enumerate(self.parts):
            core = part.core
            if core.first_motion_state or core.awaiting_first_command:
                if found is not None:
                    return None
                found = (i, core.start_reads)
        return found

    # -- the cycle -------------------------------------------------------------------------------
    def receive(self, robot: int, command) -> bool:
        """Robot `robot`'s decoded RobotCommand; True when it was the last answer the open state
        waited for."""
        if not self.parts[robot].receive(command):
            return False
        awaited = self._awaited
        if robot not in awaited:
            return False
        awaited.discard(robot)
        return not awaited

    def release(self) -> WorldReleased:
        parts = self.parts
        for part in parts:
            part.drive()
        self.step()
        released = WorldReleased(tuple(map(_publish, parts)))
        self._await()
        self.events.released(released.message_id)
        return released

    def repeat(self) -> WorldReleased:
        released = WorldReleased(tuple(map(_repeat, self.parts)))
        self._await()
        self.events.repeated(released.message_id)
        return released

    def skip(self, cycles: int) -> None:
        """Every robot's clock moves on `cycles` ids with no state and nothing stepped (the
        world at rest, nothing under way: what `cycles` repeats would leave, unsent)."""
        first = self.message_id + 1
        for part in self.parts:
            part.skip(cycles)
        self.events.skipped(first, first + cycles - 1)

    def rewind(self, message_id: int) -> None:
        """Every robot's clock back to `message_id`, the last state that left: a cycle released
        ahead (realtime, idle) is taken back before a reset, its state never sent. All robots
        alike: their states of a cycle carry one message_id."""
        for part in self.parts:
            part.core.message_id = message_id

    def hold(self) -> WorldReleased | None:
        """A motion awaits its client's first command: its window closes as at any release
        (the miss is counted, and enforcement may end the motion); while that changes nothing,
        the world is left as it is and each robot's last state goes again under the next
        message_id (its motion's window open for it). None: something changed, release.

        libfranka reads a state or two after the motion's first before it answers one, and how
        many depends on how fast the client runs; holding the world meanwhile makes its first
        command meet the same world in every run (a lockstep clock's choice, server/clock.py)."""
        for part in self.parts:
            if part.awaiting_first_command:
                part.core.release_cycle()
        if not self.holds_start:
            return None
        return self.repeat()

    def complete(self, released: WorldReleased) -> WorldReplies:
        replies, any_replies = [], False
        for part, robot in zip(self.parts, released.robots):
            part_replies = part.complete(robot)
            replies.append(part_replies)
            any_replies = any_replies or part_replies is not NO_REPLIES
        if any_replies:
            return WorldReplies(tuple(replies))
        return self.nothing

    def _await(self) -> None:
        """Whose answers the state just released waits for: every robot whose client streams,
        one whose motion still awaits its client's first command too (beside another robot's
        stream its client would otherwise fall behind by however slow it is to start); with
        none, the robots whose motion's first state it is (an answer is taken at once). A
        client gone silent (its robot braked and held until it is heard again: paused in a
        debugger, stopped) is waited for only while no other robot's client streams: a window
        a cycle for it would hold the others to ten cycles a second. Heard again, if only late
        (not waited for, its answers come after the others' released the cycle), it is waited
        for again, and its next answer is on time."""
        streaming, silent, first = set(), set(), set()
        for i, part in enumerate(self.parts):
            core = part.core
            if core.first_motion_state:
                first.add(i)
            elif core.streams_commands:
                (silent if core.client_silent and not core.answered_late
                 else streaming).add(i)
        awaited = streaming or silent or first
        self.waits_for = frozenset(awaited)
        self._awaited = awaited
