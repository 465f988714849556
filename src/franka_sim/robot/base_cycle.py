"""The mobile base's part of a world cycle, sans-IO (the contract: robot/cycle.py).

It runs the same sequence as an arm's part (receive, drive, the world's step, publish,
complete), so the base's state carries the world's message_id. What its drive gives the
physics is the base's planar pose (x, y, yaw), which `physics` (a follower with
`command(x, y, yaw)`: physics/mobile_base.py) puts the base's body at before the step, so the
arms on it ride along.
"""

from __future__ import annotations

from franka_sim.robot.base_core import BaseCore
from franka_sim.robot.cycle import NO_REPLIES, PacerQuestions, Released, Replies


class StandingStill:
    """A base with no body in the world (a core tested alone): its pose goes nowhere."""

    def command(self, x: float, y: float, yaw: float) -> None:
        pass


class BaseCycle(PacerQuestions):
    tool_busy = False  # a base has no tool

    def __init__(self, core: BaseCore, physics=None) -> None:
        self.core = core
        self.physics = physics if physics is not None else StandingStill()
        self.completed_id = 0

    @property
    def busy(self) -> bool:
        return self.core.busy

    @property
    def at_rest(self) -> bool:
        return not self.core.busy

    def receive(self, command) -> bool:
        return self.core.receive_command(command)

    def drive(self) -> None:
        self.physics.command(*self.core.release_cycle())

    def release(self) -> Released:
        """Alone (no arms: tests): the base moves, its body follows, the state is packed."""
        self.drive()
        return self.publish()

    def publish(self) -> Released:
        state = self.core.publish()
        return Released(self.core.message_id, state, None)

    def skip(self, cycles: int) -> None:
        """(Only between completed cycles: the ids skipped count as completed.)"""
        self.core.skip(cycles)
        self.completed_id = self.core.message_id

    def repeat(self) -> Released:
        state = self.core.republish()
        return Released(self.core.message_id, state, None)

    def complete(self, released: Released) -> Replies:
        self.completed_id = released.message_id
        replies = self.core.take_replies()
        return Replies(replies) if replies else NO_REPLIES
