"""Automatic error recovery: answered once the arm has come to rest, as the robot does.

The robot waits for the reflex's braking to end before it clears the errors and answers, within
a bound well inside libfranka's 1 s TCP timeout. A raw client may ask again while a recovery is
under way; every request is answered when it completes.
"""

from __future__ import annotations

import numpy as np

RECOVERY_MAX_CYCLES = 700
RECOVERY_REST_VELOCITY = 1e-3  # rad/s


class Recovery:
    """One recovery under way: the command_ids waiting for it, and the cycles waited."""

    def __init__(self, command_id: int) -> None:
        self.command_ids = [command_id]
        self.waited = 0

    def also_answer(self, command_id: int) -> None:
        self.command_ids.append(command_id)

    def done(self, dq: np.ndarray) -> bool:
        """One more cycle: True once the arm is at rest (or the wait is over)."""
        if float(np.max(np.abs(dq))) < RECOVERY_REST_VELOCITY or self.waited >= RECOVERY_MAX_CYCLES:
            return True
        self.waited += 1
        return False
