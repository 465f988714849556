"""The cycle of a world of several arms, sans-IO: every arm's cycle, around one physics step.

Each arm is a whole robot (its own core, Hand, commands and replies: robot/cycle.py); what they
share is the world, so they share its clock. A world cycle gives every arm its command
(`RobotCycle.drive`), steps the world once, and has every arm publish its state
(`RobotCycle.publish`): all arms' states of a cycle carry the same message_id and show the same
instant, so contact between two arms is seen by both in the same cycle.

`WorldCycle` answers a pacer's questions as one robot would (server/cycle_driver.py runs it
exactly as it runs one arm's cycle): a client motion anywhere makes the world client-driven,
and in lockstep the next cycle waits for the answers of every arm whose client streams
commands. An arm whose motion has just started (libfranka never answers that first state) is
not waited for while another streams; alone, it sets the pace as a lone arm's would.
"""

from __future__ import annotations

from typing import Callable, Sequence

from franka_sim.robot.cycle import NO_REPLIES, Released, Replies, RobotCycle


class WorldReleased:
    """A released world cycle: its message_id, one Released per arm, and their states (a
    tuple, one per arm, None where packing failed) for the sender."""

    __slots__ = ("message_id", "arms", "state")

    def __init__(self, arms: tuple[Released, ...]) -> None:
        self.arms = arms
        self.message_id = arms[0].message_id
        self.state = tuple(released.state for released in arms)


class WorldReplies:
    """What a completed world cycle leaves to write, one Replies per arm (by position)."""

    __slots__ = ("arms",)

    def __init__(self, arms: tuple[Replies, ...]) -> None:
        self.arms = arms

    def __bool__(self) -> bool:
        return any(self.arms)

    def then(self, later: "WorldReplies") -> "WorldReplies":
        return WorldReplies(tuple(a.then(b) for a, b in zip(self.arms, later.arms)))


class WorldCycle:
    """The arms' cycles (in a fixed order: a world cycle runs them in it, so the same command
    streams give the same bits) and `step`, the world's one physics step."""

    def __init__(self, cycles: Sequence[RobotCycle], step: Callable[[], None]) -> None:
        if len(cycles) < 2:
            raise ValueError("a world cycle is for several arms (one arm: its RobotCycle)")
        self.cycles = tuple(cycles)
        self.step = step
        # Whom the open state waits for (lockstep), by robot index: `waits_for` as released,
        # `_awaited` those of them that have not answered yet.
        self.waits_for: frozenset[int] = frozenset()
        self._awaited: set[int] = set()
        self._nothing = WorldReplies(tuple(NO_REPLIES for _ in self.cycles))

    # -- questions a pacer asks, about the world -------------------------------------------------
    @property
    def message_id(self) -> int:
        return self.cycles[0].message_id

    @property
    def in_motion(self) -> bool:
        return any(c.in_motion for c in self.cycles)

    @property
    def lockstep_applies(self) -> bool:
        return any(c.lockstep_applies and not c.first_motion_state for c in self.cycles)

    @property
    def first_motion_state(self) -> bool:
        """A motion's first state is out and no other arm's client streams: the next goes one
        period after it, as for a lone arm."""
        return (any(c.first_motion_state for c in self.cycles)
                and not self.lockstep_applies)

    @property
    def client_driven(self) -> bool:
        return any(c.client_driven for c in self.cycles)

    @property
    def busy(self) -> bool:
        return any(c.busy for c in self.cycles)

    @property
    def hand_busy(self) -> bool:
        return any(c.hand_busy for c in self.cycles)

    @property
    def at_rest(self) -> bool:
        return all(c.at_rest for c in self.cycles)

    # -- the cycle -------------------------------------------------------------------------------
    def receive(self, arm_command: tuple[int, object]) -> bool:
        """(arm index, decoded RobotCommand); True when it was the last answer the open state
        waited for."""
        index, command = arm_command
        if not self.cycles[index].receive(command):
            return False
        awaited = self._awaited
        if index not in awaited:
            return False
        awaited.discard(index)
        return not awaited

    def release(self) -> WorldReleased:
        for cycle in self.cycles:
            cycle.physics.command(*cycle.drive())
        self.step()
        released = WorldReleased(tuple(cycle.publish() for cycle in self.cycles))
        self._await()
        return released

    def repeat(self) -> WorldReleased:
        released = WorldReleased(tuple(cycle.repeat() for cycle in self.cycles))
        self._await()
        return released

    def complete(self, released: WorldReleased) -> WorldReplies:
        replies = tuple(cycle.complete(arm) for cycle, arm in zip(self.cycles, released.arms))
        if any(replies):
            return WorldReplies(replies)
        return self._nothing

    def _await(self) -> None:
        """Whose answers the state just released waits for: every robot whose client streams;
        with none, the robots whose motion's first state it is (an answer is taken at once).
        The one answer to that question: the faults ask it too (`waits_for`)."""
        cycles = self.cycles
        awaited = {i for i, c in enumerate(cycles)
                   if c.lockstep_applies and not c.first_motion_state}
        awaited = awaited or {i for i, c in enumerate(cycles) if c.first_motion_state}
        self.waits_for = frozenset(awaited)
        self._awaited = awaited
