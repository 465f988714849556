"""The one interface every command-stream checker has, and how they report what trips.

A checker follows one signal of one Move (a fresh one per Move). Each applied command is
differentiated by backward differences and held to the limits; what trips comes back as
`Violation`s named with the FCI error the robot would latch. Enforcing (latching, reflex, the
Move reply) is the caller's business.

Time is whatever the caller says: `cycles` is the interval the server observed since the
previously applied command. Each first difference belongs to the middle of its interval, so the
next order divides by the distance between those middles (SampleGrid). On whole 1 ms cycles that
is plain backward Euler; after a burst of late datagrams it measures the rate the client really
commanded, where dividing every order by the last interval alone would overstate the first
regular cycle's acceleration (n+1)/2-fold. A client that resumes from its own stale waypoint
has commanded a real jump, and trips.
"""

from __future__ import annotations

from franka_sim.robot.checks.figures import ErrorNames
from franka_sim.robot.checks.violation import Violation

_PER_SECOND = {"velocity": "/s", "acceleration": "/s²", "jerk": "/s³"}


class CommandChecker:
    """Judges one signal of a Move's command stream; subclasses implement `judge`."""

    def check(self, command, cycles: int) -> list[Violation]:
        """Judge one applied command, `cycles` (≥ 1) cycles after the previously applied one.

        Call it for applied commands only; a cycle without one (lost, or overtaken by a newer
        datagram) simply widens the next call's `cycles`.

        `command`: a decoded RobotCommand (or a mapping with its field names), finite — the
        core drops non-finite datagrams before applying them.
        """
        if cycles < 1:
            raise ValueError(f"cycles must be ≥ 1, got {cycles}")
        out: list[Violation] = []
        self.judge(command, cycles, out)
        return out

    def judge(self, command, cycles: int, out: list) -> None:
        """Append what `command` breaks to `out`, and advance the signal's history."""
        raise NotImplementedError

    def resume(self, q_d) -> None:
        """Cycles went by without a command: the robot's own reference went on meanwhile
        (carried on, or braked to rest and held) and is now at `q_d`, where the next command
        takes over. A signal the robot integrates goes on from there."""


class CheckerChain(CommandChecker):
    """Several checkers judging the same command stream, reported in their order."""

    def __init__(self, *checkers: CommandChecker) -> None:
        self.checkers = checkers
        self._judges = tuple(checker.judge for checker in checkers)

    def check(self, command, cycles: int) -> list[Violation]:
        # The loop inlined rather than through judge(): one Python call fewer per cycle.
        if cycles < 1:
            raise ValueError(f"cycles must be ≥ 1, got {cycles}")
        out: list[Violation] = []
        for judge in self._judges:
            judge(command, cycles, out)
        return out

    def judge(self, command, cycles: int, out: list) -> None:
        for judge in self._judges:
            judge(command, cycles, out)

    def resume(self, q_d) -> None:
        for checker in self.checkers:
            checker.resume(q_d)


def first_over(out: list, names: ErrorNames, axis: str, unit: str, checks) -> None:
    """Report the first derivative over its threshold; `checks` holds (value, threshold,
    nominal) for acceleration, jerk and velocity, in that order.

    A step trips all three at once. The lowest-order discontinuity is its cause, and a
    discontinuity wins over the velocity limit, which is for a signal smoothly too fast.
    """
    for quantity, name, (value, threshold, nominal) in zip(
            ("acceleration", "jerk", "velocity"), (names.acceleration, names.jerk, names.velocity),
            checks):
        if not value <= threshold:
            out.append(Violation(name, axis, float(value), float(nominal), quantity=quantity,
                                 unit=unit + _PER_SECOND[quantity]))
            return
