"""When to release the next cycle: the clock policy, as pure arithmetic on monotonic times.

The robot's time is the cycle counter; this only decides the wall-clock instant at which the
next cycle is released. `realtime` keeps absolute 1 ms deadlines (t0 + k·1 ms) so the rate has
no drift, but never sends two states closer than `min_spacing`: after an overrun it catches up
at up to 2 kHz instead of bursting. The spacing counts from the moment the previous state left,
not from when its cycle was released: a thread held up between releasing a cycle and sending
its state (not run by the machine for a while) would otherwise send that late state and the
next on-time one back to back. It re-anchors after a stall too long to catch up (a frozen
host), because no client benefits from a flood of stale cycles: the robot's time then runs
slower than the wall clock, which the pacer counts (`stalls`, `behind`) for the log.
`lockstep` (only while a motion runs) releases the next cycle as soon as the command
answering the current one arrives, and otherwise waits up to LOCKSTEP_WINDOW of wall time, from when the state left, for it: long
enough that a client descheduled on a loaded machine (CI) loses no cycle, so the outcome of a
run does not depend on the host's timing; short enough that a client that went away is still
noticed (20 lost cycles take 2 s). Idle in lockstep, the same window is how long the clock
holds at rest for the client's next request (cycle_driver.py).
"""

from __future__ import annotations

from dataclasses import dataclass

from franka_sim.protocol.timing import CYCLE_PERIOD as PERIOD

LOCKSTEP_WINDOW = 0.1  # s of wall time a lockstep cycle waits for its answer


@dataclass
class Pacer:
    period: float = PERIOD
    min_spacing: float = 0.5e-3
    max_lag: float = 0.020
    _t0: float | None = None
    _k: int = 0
    stalls: int = 0  # re-anchors after a stall: the robot's time fell behind the wall clock
    behind: float = 0.0  # s of wall time those stalls lost, in all

    def next_deadline(self, sent_at: float, *, lockstep: bool) -> float:
        """The deadline of the cycle after the one whose state left at `sent_at`."""
        if lockstep:
            self._t0 = None  # realtime pacing re-anchors when lockstep ends
            return sent_at + LOCKSTEP_WINDOW
        if self._t0 is None:
            self._t0, self._k = sent_at, 0
        self._k += 1
        deadline = self._t0 + self._k * self.period
        if sent_at - deadline > self.max_lag:
            self.stalls += 1
            self.behind += sent_at - deadline
            self._t0, self._k = sent_at, 1
            deadline = sent_at + self.period
        return max(deadline, sent_at + self.min_spacing)

    def restart(self) -> None:
        """The clock paused: the next realtime deadline anchors anew (no stall)."""
        self._t0 = None

    @staticmethod
    def extend(deadline: float) -> float:
        """Lockstep: a window that ran out while the server kept its client waiting, again."""
        return deadline + LOCKSTEP_WINDOW
