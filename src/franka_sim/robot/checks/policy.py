"""Enforce or log: what a limit violation does.

Enforced (`--enforce-motion-limits`), a check runs before the command reaches the physics and
its aborting violations end the motion. Not enforced, its only outcome is a log line, so it is
queued and run once the state has left: a lockstep client does not wait for it.
"""

from __future__ import annotations

from franka_sim.robot.motion_guard import ViolationLog, error_names


class LimitPolicy:
    def __init__(self, enforce: bool) -> None:
        self.enforce = enforce
        self._log = ViolationLog()
        self._queued: list[tuple] = []

    def judge(self, check, *args) -> list[str]:
        """The error names to abort on now (empty: none, or queued to run later)."""
        if not self.enforce:
            self._queued.append((check, *args))
            return []
        violations = check(*args)
        if not violations:
            return []
        self._log.report(violations, True)
        return error_names(violations)

    def run_deferred(self) -> None:
        """The queued checks, in the order they were queued (they only log)."""
        queued = self._queued
        if not queued:
            return
        self._queued = []
        for check, *args in queued:
            violations = check(*args)
            if violations:
                self._log.report(violations, False)
