"""What the robot says about itself: its mode, its error bits, and the replies it owes.

The robot mode, the latched errors and the reflex reason are the status fields of every
RobotState; a reflex latches error bits and ends the running Move with kReflexAborted. The
replies the robot produces on its own (a Move's final status, a recovery's success) queue here
until the server sends them after the state that shows them. `flags_version` moves whenever
the error bits change, so the publisher rewrites them only then.
"""

from __future__ import annotations

import numpy as np

from franka_sim.protocol.enums import Command, MoveStatus, RobotMode
from franka_sim.protocol.errors import NUM_ERRORS, error_index
from franka_sim.protocol.robot_messages import build_response

_NO_REPLIES: list[bytes] = []  # what take_replies gives when there are none (never written to)


class RobotStatus:
    def __init__(self) -> None:
        self._mode = RobotMode.kIdle
        # The Desk holds the arm (brakes locked, or Programming mode): an idle arm reads as
        # kOther, which no Move is admitted in (robot/admission.py), as on the robot.
        self.held = False
        self.errors = np.zeros(NUM_ERRORS, dtype=bool)
        self.reflex_reason = np.zeros(NUM_ERRORS, dtype=bool)
        self.flags_version = 0
        self.replies: list[bytes] = []

    @property
    def robot_mode(self) -> RobotMode:
        mode = self._mode
        return RobotMode.kOther if self.held and mode is RobotMode.kIdle else mode

    @robot_mode.setter
    def robot_mode(self, mode: RobotMode) -> None:
        self._mode = mode

    def latch(self, names: list[str]) -> None:
        """A reflex: the named errors latch, and become the reflex reason."""
        for name in names:
            self.errors[error_index(name)] = True
            self.reflex_reason[error_index(name)] = True
        self.flags_version += 1

    def motion_started(self) -> None:
        """The modes flip to Move; the last reflex's reason is no longer the news."""
        self.robot_mode = RobotMode.kMove
        self.reflex_reason[:] = False
        self.flags_version += 1

    def clear_errors(self) -> None:
        self.errors[:] = False
        self.flags_version += 1

    def answer_move(self, command_id: int, status: MoveStatus) -> None:
        self.replies.append(build_response(Command.Move, command_id, status))

    def take_replies(self) -> list[bytes]:
        replies = self.replies
        if not replies:
            # Not the live list, which a later cycle's reply is appended to: an earlier
            # cycle's replies still waiting to go out (a tool's state with them) would send
            # it too. One shared empty list, never written to: no new list per cycle.
            return _NO_REPLIES
        self.replies = []
        return replies
