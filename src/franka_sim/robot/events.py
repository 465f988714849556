"""What the robot tells whoever listens (a recording), as it happens: the facts a record of a
run needs that nobody outside could read off it without reaching into it.

A robot's part of the world emits `RobotEvents` (a command it took and its fate, a cycle it
lost and how it filled it), the world's cycle `WorldEvents` (each cycle released, each repeated
without a step). Both do nothing here; server/recorder/taps.py listens. One object of each is
handed in where the robot is built (assembly.py), as aioquic hands a connection its logger.
"""

from __future__ import annotations


class RobotEvents:
    def command(self, command, on_time: bool) -> None:
        """The robot took a RobotCommand; `on_time`: it answered the open cycle in time."""

    def lost(self, message_id: int, filled: str) -> None:
        """The window of state `message_id` closed without its answer; `filled`: what the
        robot made of the cycle (LOST_FILLS)."""


class WorldEvents:
    def released(self, message_id: int) -> None:
        """The world stepped into cycle `message_id`."""

    def repeated(self, message_id: int) -> None:
        """Cycle `message_id` left the world as it was (lockstep's idle time or hold)."""

    def skipped(self, first: int, last: int) -> None:
        """Cycles `first`..`last` went by with no state (an idle gap rounded up)."""


NO_ROBOT_EVENTS, NO_WORLD_EVENTS = RobotEvents(), WorldEvents()

# What a lost cycle became: the reference went on at constant acceleration (torques held);
# no command yet, the motion holds its start; braked, past the cycles the robot extrapolates;
# an async motion's generator went on; a command for a cycle not yet published was applied;
# the loss ended the motion.
EXTRAPOLATED, HELD, BRAKED, GENERATED, NEWER_COMMAND, MOTION_ENDED = (
    "extrapolated", "held", "braked", "generated", "newer command", "motion ended")
LOST_FILLS = (EXTRAPOLATED, HELD, BRAKED, GENERATED, NEWER_COMMAND, MOTION_ENDED)
