"""Enforce or only log: what a motion-limit violation does (`--enforce-motion-limits`).

Enforced, a check runs where it must, before the command reaches the physics, and the errors it
latches abort the motion. Not enforced, its only outcome is a log line, which need not hold up
the state a client is waiting for (a lockstep cycle is ~7 % faster without it): the check is
queued with its inputs and run once the state has left.
"""

from __future__ import annotations

from franka_sim.robot.checks.violation import ViolationLog, error_names


class LimitPolicy:
    def __init__(self, enforce: bool) -> None:
        self.enforce = enforce
        self.log = ViolationLog()
        self._queued: list[tuple] = []  # (check, args), in the order judge() saw them

    def judge(self, check, *args) -> list[str]:
        """Enforced: run check(*args) now, log its violations, and return the error names to
        abort on (empty: none). Not enforced: queue it and return []."""
        if not self.enforce:
            self._queued.append((check, args))
            return []
        violations = check(*args)
        if not violations:
            return []
        self.log.report(violations, True)
        return error_names(violations)

    def run_deferred(self) -> None:
        """Run the queued checks in order, logging (never aborts). The server calls it once the
        state has left; the next cycle runs any left over first, so their order never changes."""
        queued = self._queued
        if not queued:
            return
        self._queued = []
        for check, args in queued:
            violations = check(*args)
            if violations:
                self.log.report(violations, False)
