"""What the operations ask of the simulator that runs them, as protocols: the server's cycle
thread and driver (server/) fit them, and so do replay's in-line stand-ins
(playback/replay.py), so the operations import nothing from either."""

from __future__ import annotations

from typing import Any, Callable, Protocol


class Jobs(Protocol):
    """The thread that owns the world's physics (server/cycle_thread.py's CycleThread)."""

    failure: str | None  # why it stopped stepping the world (None: it runs)

    async def call(self, fn: Callable[[Any], Any]) -> Any:
        """fn(the world's physics: one backend per arm) between two cycles; its result, or
        the exception it returned, raised here."""


class Pacer(Protocol):
    """The world's cycle driver (server/cycle_driver.py's CycleDriver)."""

    def withdraw_prepared(self) -> int | None:
        """Take back the idle cycle released ahead (its state not sent): its message_id."""

    def keep_running(self, cycles: int = 0) -> None:
        """A change was made that acts for `cycles` (a push): run the clock that long and a
        while more, even with no client."""
