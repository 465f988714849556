"""What a check reports: a `Violation` named as the robot names it, the error bits a set of
them latches, and the thinned log line each one gets.

Checking and logging are always on; the log is rate-limited per error name so a violating
client cannot flood it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from franka_sim.protocol.errors import error_index
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

# A commanded velocity over its limit makes the safety controller trip as well (hardware is
# reported to latch both names).
COMPANION_ERRORS = {"joint_motion_generator_velocity_limits_violation": "joint_velocity_violation"}


@dataclass(frozen=True)
class Violation:
    """One limit a command (or the measured arm) broke, named as the robot names it."""

    name: str  # an ERROR_NAMES entry
    axis: str  # "joint 4", "translation", "rotation", "elbow", "frame"
    value: float  # the offending value
    limit: float  # the nominal limit it was held to (tolerances aside)
    aborts: bool = True  # False: the FCI only recommends this limit; log it, latch nothing
    quantity: str = ""  # "acceleration", "start offset", "sign", ...
    unit: str = ""

    def __post_init__(self) -> None:
        error_index(self.name)  # a typo must fail loudly, not set no bit

    def describe(self) -> str:
        """One line, e.g. "…_velocity_discontinuity: joint 4 acceleration 123.4 rad/s² > 10"."""
        relation = "≠" if self.quantity == "sign" else (">" if self.value > self.limit else "<")
        what = " ".join(part for part in (self.axis, self.quantity) if part)
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.name}: {what} {self.value:.6g}{unit} {relation} {self.limit:.6g}"


def error_names(violations: list[Violation]) -> list[str]:
    """The error bits an aborting set of violations latches (companions included)."""
    names = {v.name for v in violations if v.aborts}
    names |= {COMPANION_ERRORS[n] for n in names if n in COMPANION_ERRORS}
    return sorted(names)


class ViolationLog:
    """One warning line per violation, thinned out per error name (see thinned_log); each one
    that aborts a motion has its line (a reflex the client sees, as rare as its motions)."""

    def __init__(self) -> None:
        self._counts: dict[str, int] = {}

    def report(self, violations: list[Violation], enforced: bool) -> None:
        for v in violations:
            n = self._counts.get(v.name, 0) + 1
            self._counts[v.name] = n
            aborting = enforced and v.aborts
            if aborting or worth_logging(n):
                action = "aborting" if aborting else "not enforced"
                log.warning("%s (%s; %d so far)", v.describe(), action, n)
