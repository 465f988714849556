"""The faults of a world's robot UDP paths: one link per robot (each arm, the mobile base),
wired in only while needed. The faults' own modules (franka_sim.faults) are imported when
the first spec is checked, set or reported on: a server that never injects never loads them.

While no arm has a plan, the endpoints and the driver hold None and pay one `if` per datagram
and per lockstep decision. Setting a plan on any arm attaches every arm's link (a link without
a plan lets everything through, but still tells the driver which state each client will
answer); clearing the last one detaches them all. Set and cleared in the cycle thread (a
control API job) or before the server starts, so a cycle never sees half a change.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from franka_sim.faults.seed import check_seed
from franka_sim.server.clock import ClockWatcher

if TYPE_CHECKING:
    from franka_sim.faults import ArmLink, FaultSpec


class NetworkFaults(ClockWatcher):
    """`seed`: the server's --seed; then `wire` the world's CycleDriver (its `faults`, `cycle`)
    and each robot's UdpEndpoint (its `faults`, `target`, `late`), in the world cycle's order
    (the arms, then the mobile base). The world's clock tells it what it did (ClockWatcher),
    from its start: the counts a fate's key and a report need."""

    def __init__(self, seed: int = 0) -> None:
        self.seed = check_seed(seed)
        self.driver = None
        self.endpoints: list = []
        self.links: list[ArmLink] = []
        self.seeds: list[int | None] = []
        self.attached = False
        # Lockstep idle cycles that only repeated a state while a client lingered over the
        # window: the one part of message_id that wall time decides. Fates are keyed on
        # message_id less the count when the last motion started (so a motion's cycles get the
        # same fates in every rehearsal, and idle states after it still get fates of their own).
        self.repeats = 0
        self.key_offset = 0  # `repeats` when the last motion started: faults key on the rest
        # Lockstep: the last motion's hold (its first state's message_id, the last held one's,
        # and the first state's key). Every held state would have that key; each gets its place
        # in the hold as well, or one fate would befall every answer until the first command
        # came through, and a lost or late one would hold the motion for ever.
        self._hold = (-1, -1, 0)
        self.windows_run_out = 0  # lockstep cycles released without the answer they waited for

    def wire(self, driver, endpoints) -> None:
        """The world's driver and the robots' endpoints, by robot index (once, before any plan
        is set)."""
        self.driver = driver
        self.endpoints = list(endpoints)
        self.seeds = [None] * len(self.endpoints)
        self.links = []  # (made with the first plan or report: _linked)

    # -- what the clock did (ClockWatcher, cycle thread) -------------------------------------------
    def repeated(self) -> None:
        self.repeats += 1

    def skipped(self, cycles: int) -> None:  # what the repeats of an idle gap were rounded up by
        self.repeats += cycles

    def motion_started(self, message_id: int) -> None:
        self.key_offset = self.repeats
        self._hold = (message_id, message_id, message_id - self.key_offset)

    def held(self, message_id: int) -> None:  # within the motion: its later cycles keep their keys
        self.repeats += 1
        self.key_offset += 1
        self._hold = (self._hold[0], message_id, self._hold[2])

    def key(self, message_id: int) -> tuple[int, int]:
        """A datagram's fate key (faults/plan.py): (message_id less key_offset, 0), or for a
        held state of the last motion's start and the answers to it, (the start's key, its
        place in the hold)."""
        start, last, key = self._hold
        if start < message_id <= last:
            return key, message_id - start
        return message_id - self.key_offset, 0

    def window_ran_out(self) -> None:
        self.windows_run_out += 1

    def check(self, fields: dict) -> tuple[FaultSpec, int | None]:
        """POST /faults's fields (the spec's, or "spec"; "seed" optional) as (spec, seed; None:
        the server's), to `set` later; ValueError (FaultSpecError, a bad seed) says why not. A
        string alone is a spec (as the Python client's set_faults takes it)."""
        if isinstance(fields, str):
            fields = {"spec": fields}
        if not isinstance(fields, dict):
            raise ValueError(f"faults are a spec (\"loss=0.01\") or its fields as a dict, not "
                             f"{fields!r}")
        fields = dict(fields)
        seed = fields.pop("seed", None)
        seed = None if seed is None else check_seed(seed)
        from franka_sim.faults.spec import spec_from_fields

        return spec_from_fields(fields), seed

    def set(self, arm: int, spec: FaultSpec | None, seed: int | None = None) -> None:
        """Arm `arm`'s faults from the next datagram on (None, or a spec that injects nothing:
        none)."""
        link = self._linked()[arm]
        if spec is None or not spec.injects:
            link.set_plan(None)
            self.seeds[arm] = None
            if self.attached and all(link.plan is None for link in self.links):
                self._detach()
            return
        from franka_sim.faults.plan import FaultPlan

        seed = self.seed if seed is None else check_seed(seed)
        link.set_plan(FaultPlan(spec, seed, arm, self._next_key()))
        self.seeds[arm] = seed
        if not self.attached:
            self._attach()

    def restart_counts(self, arm: int) -> None:
        """What arm `arm`'s faults did counts from now (a reset; the plan goes on)."""
        if self.links:
            self.links[arm].restart_counts()

    def _next_key(self) -> int:
        """The next cycle's key, counting every cycle the clock only repeated so far (not just
        those before the last motion): a plan's times count from it (0 before the start)."""
        cycle = None if self.driver is None else self.driver.cycle
        return 0 if cycle is None else cycle.message_id + 1 - self.repeats

    def report(self, arm: int) -> dict:
        """What is set on arm `arm` and what it did (GET /faults)."""
        link = self._linked()[arm]
        plan = link.plan
        held_states, held_commands = link.held
        return {
            "spec": None if plan is None else plan.spec.text(),
            "fields": None if plan is None else plan.spec.fields(),
            "seed": self.seeds[arm] if plan is not None else self.seed,
            # a fate is keyed on message_id less this: the cycles lockstep's idle clock only
            # repeated (a client lingering) before the last motion started (docs/robustness.md)
            "key_offset": self.key_offset,
            # the key the plan counts from (its burst times, its fates): set at the next cycle
            "origin": None if plan is None else plan.origin,
            # lockstep cycles that went without the answer they waited for (window run out)
            "windows_run_out": self.windows_run_out,
            "states": dict(link.counts["states"], held=held_states),
            "commands": dict(link.counts["commands"], held=held_commands),
        }

    # -- the driver's question (cycle thread) ------------------------------------------------------
    def answered(self, cycle) -> bool:
        """Lockstep: every client whose answer the world waits for has answered the state it
        was last sent, or was sent none new (nothing to wait for). Asked with the world's cycle:
        a lone arm's RobotCycle, or a WorldCycle, whose `waits_for` says whom it waits for."""
        links = self.links
        if len(links) == 1:
            link = links[0]
            return link.fresh is None or link.answered
        return all(links[i].fresh is None or links[i].answered for i in cycle.waits_for)

    # -- wiring ------------------------------------------------------------------------------------
    def _linked(self) -> list[ArmLink]:
        """Each robot's link, made on first use."""
        if not self.links:
            from franka_sim.faults.link import ArmLink

            self.links = [ArmLink(i, self.key) for i in range(len(self.endpoints))]
        return self.links

    def _attach(self) -> None:
        """Every arm's link into its endpoint, this into the driver. The state last sent went
        out whole: each client is taken to answer it."""
        cycle = self.driver.cycle
        open_id = -1 if cycle is None else cycle.message_id
        for link, endpoint in zip(self.links, self.endpoints):
            link.new_client(endpoint.target)
            link.now = link.newest = open_id
            link.fresh = open_id if open_id >= 0 else None
            endpoint.faults = link
        self.driver.faults = self
        self.attached = True

    def _detach(self) -> None:
        """Back to the plain path: held commands reach the robot at the next read (late), held
        states are dropped (the client has newer ones, or gets the next)."""
        self.driver.faults = None
        for link, endpoint in zip(self.links, self.endpoints):
            endpoint.faults = None
            endpoint.late.extend(link.take_held_commands())
        self.attached = False
