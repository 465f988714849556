"""Each datagram's fate, as a pure function of (seed, arm, direction, message_id).

Not a random stream consumed in arrival order: a datagram's fate does not depend on what came
before it or when, so in lockstep the same seed hits the same cycles and a rehearsal reproduces
to the bit, and a state and the command answering it are decided independently. A state is
keyed on its own message_id, a command on the one it echoes (the state it answers).

The numbers come from BLAKE2b over the key: three 64-bit words per datagram, one each for the
loss, the latency and the reordering. Standard library only.
"""

from __future__ import annotations

import hashlib
import struct

from franka_sim.faults.seed import MAX_SEED, check_seed
from franka_sim.faults.spec import FaultSpec

STATES, COMMANDS = 0, 1
DIRECTION_NAMES = ("states", "commands")
_KEY = struct.Struct("<QIBQ")
_HELD_KEY = struct.Struct("<QIBQQ")  # a held cycle's: its place in the hold too
_PERSON = b"franka-sim-fault"  # (16 bytes: BLAKE2b's personalisation)
_TO_UNIT = 2.0 ** -53


def _standard_normal():
    from statistics import NormalDist

    return NormalDist()


class FaultPlan:
    """The fates a spec gives one arm's datagrams under one seed."""

    def __init__(self, spec: FaultSpec, seed: int, arm: int, origin: int = 0) -> None:
        """`origin`: the key the plan counts from (the next cycle's when it was set): a burst
        `@Ts` falls T s after that, and a datagram's fate is keyed on its key less it, so a
        plan set again the same way meets the same fates whatever the clock did before."""
        self.spec, self.seed, self.arm, self.origin = spec, check_seed(seed), arm, origin
        self._directions = {"both": (STATES, COMMANDS), "states": (STATES,),
                            "commands": (COMMANDS,)}[spec.dir]
        self._bursts = tuple((b.start, b.start + b.cycles) for b in spec.bursts)
        self._random = bool(spec.loss or spec.jitter or spec.reorder)
        self._delay_us = round(spec.delay * 1000)
        # (statistics, with the fractions and decimal it imports, ~0.4 MiB: only for jitter)
        self._normal = _standard_normal() if spec.jitter else None

    def fate(self, direction: int, message_id: int, held: int = 0) -> tuple[int, bool] | None:
        """None: lost. Else (cycles, reordered): held for that many cycles (0: goes now), and
        whether it also trades places with the next datagram. `held`: the datagram belongs to
        the j-th state of a lockstep motion's hold (its answer too), `message_id` being the
        key of the motion's first state: fates of their own, and a burst reaches it as it
        reaches the j-th cycle after that state."""
        if direction not in self._directions:
            return 0, False
        message_id -= self.origin  # (< 0: a command answering a state from before the plan)
        for start, end in self._bursts:
            if start <= message_id + held < end:
                return None
        if not self._random:
            return (self._delay_us + 999) // 1000, False
        spec = self.spec
        u_loss, u_latency, u_reorder = self.uniforms(direction, message_id, held)
        if u_loss < spec.loss:
            return None
        latency_us = self._delay_us
        if spec.jitter:
            z = self._normal.inv_cdf(u_latency)
            latency_us = max(0, latency_us + round(spec.jitter * 1000 * z))
        return (latency_us + 999) // 1000, u_reorder < spec.reorder

    def uniforms(self, direction: int, message_id: int,
                 held: int = 0) -> tuple[float, float, float]:
        """Three numbers in (0, 1) for this datagram, the same on every run and machine."""
        if held:
            key = _HELD_KEY.pack(self.seed, self.arm, direction, message_id & MAX_SEED, held)
        else:
            key = _KEY.pack(self.seed, self.arm, direction, message_id & MAX_SEED)
        digest = hashlib.blake2b(key, digest_size=24, person=_PERSON).digest()
        words = struct.unpack("<3Q", digest)
        return tuple(((word >> 11) + 0.5) * _TO_UNIT for word in words)
