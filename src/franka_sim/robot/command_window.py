"""The command window: which published state each RobotCommand answered.

Every published state opens a cycle; a command echoing that state's message_id that arrives
before the next cycle is released closes it on time. The release of the next cycle is the end
of the window (the robot's "< 1 ms" budget), so this module never looks at a clock: the server
calls `opened` when it publishes and `close` when it releases the next cycle. A late answer
(to a cycle whose window already closed) is dropped, as the robot drops it: that cycle was
extrapolated, and applying the client's value for it a cycle later would step the stream back
by one cycle's travel, a discontinuity no real robot shows. Missed cycles, late answers and
ids that were never published all count as lost, which is what
control_command_success_rate reports (share of the last 100 cycles answered on time). The rate
starts with the first command the motion receives: libfranka never answers the state on which
the modes flip (it is how it learns the motion started), so counting the cycles before its
first command would report every libfranka client as lossy. Consecutive losses still count
from the start, so a client that never sends is aborted all the same.

A late answer is kept aside for the cycle (`late`), its values never applied to a stream: a
client whose every answer is late (a round trip over one cycle, as a network delay makes it) is
still heard, which a server that does not abort it needs to know (its finish,
robot/arm_core.py). An async motion's target is no stream: it is taken late too.
"""

from __future__ import annotations

from collections import deque

WINDOW = 100


class CommandWindow:
    def __init__(self) -> None:
        self.open_id: int | None = None  # message_id of the cycle awaiting its answer
        self._answered = False
        self._latest = None
        self._latest_id = -1
        self._history: deque[bool] = deque(maxlen=WINDOW)
        self._answered_in_window = 0
        self.consecutive_lost = 0
        self.lost_total = 0
        self.answered_total = 0
        self.invented_total = 0
        self.late_total = 0
        self._late = None
        self.late = None  # the newest late answer in the cycle last closed (dropped), or None
        self.late_in_row = 0  # closed cycles in a row with no answer on time but a late one

    def opened(self, message_id: int) -> None:
        self.open_id = message_id
        self._answered = False

    def take(self, message_id: int, command) -> bool:
        """Take a command; True if it answers the open cycle in time (lockstep may go on)."""
        if message_id < self._latest_id:
            return False  # overtaken by a newer command already received
        if self.open_id is not None and message_id < self.open_id:
            self.late_total += 1  # its cycle is gone (extrapolated): dropped
            if self._late is None or message_id >= self._late[0]:  # (the last sent)
                self._late = (message_id, command)
            return False
        if self.open_id is not None and message_id > self.open_id:
            self.invented_total += 1  # never published: applied, but it answers nothing
        self._latest, self._latest_id = command, message_id
        if message_id == self.open_id and not self._answered:
            self._answered = True
            return True
        return False

    def close(self):
        """The window of the open cycle ends (the next one is being released): the command to
        apply next (the one that answered it, or a newer one), or None; `consecutive_lost` and
        the rate count this cycle from now on."""
        on_time = self._answered
        if self._latest is not None or self._history or on_time:  # from the first command on
            if len(self._history) == WINDOW:
                self._answered_in_window -= self._history[0]
            self._history.append(on_time)
            self._answered_in_window += on_time
        if on_time:
            self.answered_total += 1
            self.consecutive_lost = 0
        else:
            self.lost_total += 1
            self.consecutive_lost += 1
        command, self._latest = self._latest, None
        self.late = None if self._late is None else self._late[1]
        self._late = None
        self.late_in_row = 0 if on_time or self.late is None else self.late_in_row + 1
        self.open_id = None
        return command

    @property
    def holds_command(self) -> bool:
        """A command arrived that the window's close has still to apply."""
        return self._latest is not None

    def silence(self, what: str, holding: str) -> str:
        """The one line a robot logs when its motion's client missed `consecutive_lost` cycles
        in a row: silent (`holding`: what the robot does until it is heard again), or heard
        only late."""
        if not self.late_in_row:
            return f"client silent for {self.consecutive_lost} cycles: {what}, {holding}"
        return (f"no command on time for {self.consecutive_lost} cycles, the last "
                f"{self.late_in_row} answered after their cycle closed (a round trip over one "
                f"cycle, as a network delay makes it) and dropped: {what}; a late command's "
                f"finish still ends the motion")

    @property
    def success_rate(self) -> float:
        if not self._history:
            return 0.0
        return self._answered_in_window / len(self._history)
