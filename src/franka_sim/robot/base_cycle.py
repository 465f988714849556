"""The mobile base's control cycle, sans-IO: one more robot of a world cycle.

It answers a pacer's questions and runs the same sequence as an arm's RobotCycle (receive,
drive, the world's step, publish, complete), so robot/world_cycle.py and the server's driver
run it beside the arms: the base's state carries the world's message_id. What its drive gives
the physics is the base's planar pose (x, y, yaw), which `physics` (a follower with
`command(x, y, yaw)`: physics/mobile_base.py) puts the base's body at before the step, so the
arms on it ride along.
"""

from __future__ import annotations

from franka_sim.robot.cycle import NO_REPLIES, PacerQuestions, Released, Replies
from franka_sim.robot.mobile_base import BaseCore


class StandingStill:
    """A base with no body in the world (a core tested alone): its pose goes nowhere."""

    def command(self, x: float, y: float, yaw: float) -> None:
        pass


class BaseCycle(PacerQuestions):
    def __init__(self, core: BaseCore, physics=None) -> None:
        self.core = core
        self.physics = physics if physics is not None else StandingStill()
        self.completed_id = 0
        self.recorder = None

    # -- questions a pacer asks (and PacerQuestions') ------------------------------------------
    @property
    def busy(self) -> bool:
        return self.core.busy

    hand_busy = False  # a base has no Hand

    @property
    def at_rest(self) -> bool:
        return not self.core.busy

    # -- the cycle -------------------------------------------------------------------------------
    def receive(self, command) -> bool:
        return self.core.receive_command(command)

    def drive(self) -> tuple[float, float, float]:
        return self.core.release_cycle()

    def release(self) -> Released:
        """Alone (no arms: tests): the base moves, its body follows, the state is packed."""
        self.physics.command(*self.drive())
        return self.publish()

    def publish(self) -> Released:
        state = self.core.publish()
        return Released(self.core.message_id, state, None)

    def repeat(self) -> Released:
        state = self.core.republish()
        return Released(self.core.message_id, state, None)

    def complete(self, released: Released) -> Replies:
        self.completed_id = released.message_id
        replies = self.core.take_replies()
        return Replies(replies, [], None) if replies else NO_REPLIES
