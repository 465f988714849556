"""One arm's UDP path under a fault plan, sans-IO: what it holds, and what goes now.

Given the states the robot sends and the commands the client's socket yields (with the
message_id of the cycle whose window is open), it says which datagrams go through now and
keeps the others until their cycle comes. No socket, no clock: time is the message_id.

- A state held for k cycles leaves with the state of cycle n + k. The datagrams of one cycle
  leave newest first: libfranka takes the newest state it has, and one that a blocked client
  reads at once must be the one it would also find by draining its socket.
- A command held for k cycles reaches the robot at the first read after cycle (the open one when
  it arrived) + k was released: late, so the robot drops it, as the real one drops a late
  answer. A reordered command reaches it right after the client's next datagram (or two cycles
  on, if none comes).
- Pacing (lockstep): `fresh` is the state the client will answer, a state newer than any it was
  sent that left with the last cycle (None: nothing new reached it, nothing to wait for), and
  `answered` whether its answer came, whatever its fate: the client did answer.
"""

from __future__ import annotations

import itertools

from franka_sim.faults.plan import COMMANDS, DIRECTION_NAMES, STATES, FaultPlan

REORDER_WAIT = 2  # cycles a reordered command waits for the client's next datagram


def _no_counts() -> dict[str, dict[str, int]]:
    return {name: {"seen": 0, "dropped": 0, "delayed": 0, "reordered": 0}
            for name in DIRECTION_NAMES}


class ArmLink:
    def __init__(self, arm: int, key=lambda message_id: (message_id, 0)) -> None:
        self.arm = arm
        # message_id -> a fate's (key, held) (server/network_faults.py): message_id less the
        # cycles lockstep's clock only repeated or held (wall time decided them), so a rehearsal
        # hits the same cycles of its motions however long its client lingered.
        self.key = key
        self.plan: FaultPlan | None = None
        self.client = None  # the address the held datagrams belong to
        self.now = -1  # message_id of the last state sent: the cycle whose window is open
        self.newest = -1  # the newest state the client was sent
        self.fresh: int | None = None
        self.answered = False
        self.counts = _no_counts()
        self._states: list[tuple[int, int, bytes]] = []  # (due cycle, message_id, bytes)
        self._commands: list[tuple[int, int, object]] = []  # (due cycle, arrival, command)
        self._swapped: tuple[int, object] | None = None  # (latest due, command)
        self._arrivals = itertools.count()

    def set_plan(self, plan: FaultPlan | None) -> None:
        """From now on (counts start again with a new plan); held datagrams keep their cycle."""
        self.plan = plan
        if plan is not None:
            self.counts = _no_counts()

    def restart_counts(self) -> None:
        """Count again from zero (a reset world), whatever plan goes on."""
        self.counts = _no_counts()

    @property
    def held(self) -> tuple[int, int]:
        """(states, commands) held now."""
        return len(self._states), len(self._commands) + (self._swapped is not None)

    def new_client(self, client) -> None:
        """Another client (or none): what was held for the last one is gone with it."""
        self.client = client
        self.newest, self.fresh, self.answered = -1, None, False
        self._states.clear()
        self._commands.clear()
        self._swapped = None

    def take_held_commands(self) -> list:
        """The commands still held, all now (in arrival order), none kept; held states are
        dropped (faults cleared: nothing is held any more)."""
        held = [command for _, _, command in sorted(self._commands, key=lambda c: c[1])]
        if self._swapped is not None:
            held.append(self._swapped[1])
        self._states.clear()
        self._commands.clear()
        self._swapped = None
        return held

    # -- states, robot → client -------------------------------------------------------------------
    def states_out(self, message_id: int, data: bytes) -> list[bytes]:
        """The robot sends the state of cycle `message_id`: the datagrams to send now."""
        self.now = message_id
        out: list[tuple[int, bytes]] = []
        plan = self.plan
        if plan is None:
            out.append((message_id, data))
        else:
            counts = self.counts["states"]
            counts["seen"] += 1
            fate = plan.fate(STATES, *self.key(message_id))
            if fate is None:
                counts["dropped"] += 1
            else:
                cycles, reordered = fate
                if cycles:  # (counted as a command's are: a reordered one is not delayed)
                    counts["delayed"] += 1
                if reordered:
                    counts["reordered"] += 1
                    cycles += 1  # it leaves after the next cycle's state
                if cycles:
                    self._states.append((message_id + cycles, message_id, data))
                else:
                    out.append((message_id, data))
        if self._states:
            held = self._states
            out += [(n, d) for due, n, d in held if due <= message_id]
            self._states = [item for item in held if item[0] > message_id]
            out.sort(key=lambda item: item[0], reverse=True)
        if out and out[0][0] > self.newest:
            self.fresh = self.newest = out[0][0]
            self.answered = False
        else:
            self.fresh = None
        return [d for _, d in out]

    # -- commands, client → robot -----------------------------------------------------------------
    def commands_due(self) -> list:
        """Held commands whose cycle has come, in the order they are due."""
        if not self._commands and self._swapped is None:
            return []
        now, out = self.now, []
        if self._commands:
            due = sorted(item for item in self._commands if item[0] <= now)
            if due:
                out = [command for _, _, command in due]
                self._commands = [item for item in self._commands if item[0] > now]
        if self._swapped is not None and self._swapped[0] <= now:
            out.append(self._swapped[1])
            self._swapped = None
        return out

    def command_in(self, command) -> list:
        """A command from the client's socket: what reaches the robot now."""
        message_id = int(command["message_id"])
        if message_id == self.fresh:
            self.answered = True
        swapped, self._swapped = self._swapped, None
        plan = self.plan
        out = []
        if plan is None:
            out.append(command)
        else:
            counts = self.counts["commands"]
            counts["seen"] += 1
            fate = plan.fate(COMMANDS, *self.key(message_id))
            if fate is None:
                counts["dropped"] += 1
            elif fate[0]:
                counts["delayed"] += 1
                self._commands.append((self.now + fate[0], next(self._arrivals), command))
            elif fate[1]:
                counts["reordered"] += 1
                self._swapped = (self.now + REORDER_WAIT, command)
            else:
                out.append(command)
        if swapped is not None:
            out.append(swapped[1])
        return out
