"""Automatic error recovery: answered once the arm has come to rest, as the robot does.

The robot waits for the reflex's braking to end before it clears the errors and answers, within
a bound well inside libfranka's 1 s TCP timeout. A raw client may ask again while a recovery is
under way; every request is answered when it completes.
"""

from __future__ import annotations

import numpy as np

from franka_sim.protocol.enums import AutomaticErrorRecoveryStatus, Command, RobotMode
from franka_sim.protocol.robot_messages import build_response

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


def request_recovery(status, external, recovery: Recovery | None,
                     command_id: int) -> tuple[list[bytes], Recovery | None]:
    """An AutomaticErrorRecovery request: the replies due now, and the recovery under way."""
    if status.robot_mode is RobotMode.kMove:
        return [build_response(Command.AutomaticErrorRecovery, command_id,
                               AutomaticErrorRecoveryStatus.kCommandNotPossibleRejected)], recovery
    if not status.errors.any() and status.robot_mode is RobotMode.kIdle:
        external.clear_collisions()
        return [build_response(Command.AutomaticErrorRecovery, command_id,
                               AutomaticErrorRecoveryStatus.kSuccess)], recovery
    status.robot_mode = RobotMode.kAutomaticErrorRecovery
    if recovery is None:
        return [], Recovery(command_id)  # answered once the arm is at rest
    recovery.also_answer(command_id)  # one more request for the recovery under way
    return [], recovery


def complete_recovery(recovery: Recovery, status, external, drives, measured) -> None:
    """The arm is at rest: errors and collisions cleared, Idle, held where it stands, and every
    request answered."""
    status.clear_errors()
    external.clear_collisions()
    status.robot_mode = RobotMode.kIdle
    drives.hold_at(measured.q)
    status.replies.extend(build_response(
        Command.AutomaticErrorRecovery, command_id, AutomaticErrorRecoveryStatus.kSuccess)
        for command_id in recovery.command_ids)
