"""What faults to inject on a robot's UDP path: `loss=0.01,delay=2ms,jitter=0.5ms` as a value.

One parser for the CLI's --inject, FRANKA_SIM_INJECT and the control API's `POST /faults`, so
a spec is refused with the same one-line reason wherever it comes from. Standard library only:
the CLI checks a spec before it starts the server.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

DIRECTIONS = ("both", "states", "commands")
MAX_DELAY_MS = 1000.0  # a datagram held longer is as good as lost (and the queue stays small)
MAX_JITTER_MS = 100.0
MAX_BURST_CYCLES = 60_000
KEYS = ("loss", "delay", "jitter", "burst", "reorder", "dir")

_DURATION = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(ms|s|us)?\s*$")
_UNIT_MS = {"ms": 1.0, "s": 1000.0, "us": 1e-3, None: 1.0}


class FaultSpecError(ValueError):
    """A spec that cannot be injected; the message says why, in one line."""


@dataclass(frozen=True)
class Burst:
    """`cycles` consecutive cycles lost, from message_id `start` (simulated time in ms)."""

    start: int
    cycles: int

    def text(self) -> str:
        return f"{self.cycles}@{_number(self.start / 1000)}s"


@dataclass(frozen=True)
class FaultSpec:
    """loss and reorder are probabilities per datagram; delay and jitter are ms (a datagram's
    latency is max(0, delay + jitter·z), z standard normal); bursts lose every datagram of
    their cycles. `dir` limits all of them to one direction (default both)."""

    loss: float = 0.0
    delay: float = 0.0
    jitter: float = 0.0
    reorder: float = 0.0
    bursts: tuple[Burst, ...] = field(default=())
    dir: str = "both"

    @property
    def injects(self) -> bool:
        """Some fault acts (loss=0 alone, a sweep's baseline, injects nothing)."""
        return bool(self.loss or self.delay or self.jitter or self.reorder or self.bursts)

    def text(self) -> str:
        """The spec as --inject takes it (parse_spec(spec.text()) == spec)."""
        parts = [f"loss={_number(self.loss)}"] if self.loss else []
        if self.delay:
            parts.append(f"delay={_number(self.delay)}ms")
        if self.jitter:
            parts.append(f"jitter={_number(self.jitter)}ms")
        parts += [f"burst={burst.text()}" for burst in self.bursts]
        if self.reorder:
            parts.append(f"reorder={_number(self.reorder)}")
        if self.dir != "both":
            parts.append(f"dir={self.dir}")
        return ",".join(parts)

    def fields(self) -> dict:
        """As JSON (GET /faults): the control API's own field names and units (ms)."""
        return {"loss": self.loss, "delay": self.delay, "jitter": self.jitter,
                "burst": [burst.text() for burst in self.bursts], "reorder": self.reorder,
                "dir": self.dir}


def _number(value: float) -> str:
    return f"{value:g}" if value == float(f"{value:g}") else repr(value)


def parse_spec(text: str) -> FaultSpec:
    """`KEY=VALUE,...` (keys: loss, delay, jitter, burst, reorder, dir; burst may repeat)."""
    if not isinstance(text, str):
        raise FaultSpecError(f"a spec is a string (e.g. loss=0.01,delay=2ms), not {text!r}")
    if not text.strip():
        raise FaultSpecError("an empty spec injects nothing (e.g. loss=0.01,delay=2ms)")
    values: dict[str, object] = {}
    for part in text.split(","):
        key, sep, value = part.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise FaultSpecError(f"{part.strip()!r}: expected KEY=VALUE (e.g. loss=0.01)")
        _collect(values, key, value)
    return _build(values)


def spec_from_fields(fields: dict) -> FaultSpec:
    """The JSON form: {"loss": 0.01, "delay": 2 (ms) or "2ms", "burst": "25@3s" or a list of
    them, ...}, or {"spec": "loss=0.01,..."} alone."""
    if "spec" in fields:
        if len(fields) > 1:
            raise FaultSpecError("give either spec or the fields, not both")
        return parse_spec(fields["spec"])
    if not fields:
        raise FaultSpecError(f"no fault given (fields: {', '.join(KEYS)}; or spec)")
    values: dict[str, object] = {}
    for key, value in fields.items():
        items = value if key == "burst" and isinstance(value, list) else [value]
        for item in items:
            if isinstance(item, bool) or not isinstance(item, (int, float, str)):
                raise FaultSpecError(f"{key} must be a number or a string, not {item!r}")
            _collect(values, key, str(item) if not isinstance(item, float) else repr(item))
    return _build(values)


def _collect(values: dict, key: str, value: str) -> None:
    if key not in KEYS:
        raise FaultSpecError(f"unknown fault {key!r} (expected one of {', '.join(KEYS)})")
    if key == "burst":
        values.setdefault("bursts", []).append(_burst(value))
        return
    if key in values:
        raise FaultSpecError(f"{key} given twice")
    if key in ("loss", "reorder"):
        values[key] = _probability(key, value)
    elif key in ("delay", "jitter"):
        values[key] = _duration_ms(key, value, MAX_DELAY_MS if key == "delay" else MAX_JITTER_MS)
    elif value not in DIRECTIONS:
        raise FaultSpecError(f"dir={value}: expected {', '.join(DIRECTIONS)}")
    else:
        values[key] = value


def _build(values: dict) -> FaultSpec:
    bursts = tuple(sorted(values.pop("bursts", ()), key=lambda burst: burst.start))
    return FaultSpec(bursts=bursts, **values)


def _probability(key: str, value: str) -> float:
    try:
        p = float(value)
    except ValueError:
        raise FaultSpecError(f"{key}={value}: not a number (a probability, e.g. 0.01)") from None
    if not 0.0 <= p <= 1.0:  # (NaN fails too)
        raise FaultSpecError(f"{key}={value}: a probability is in [0, 1]")
    return p


def _duration_ms(key: str, value: str, most: float) -> float:
    match = _DURATION.match(value)
    if match is None:
        raise FaultSpecError(f"{key}={value}: not a duration (e.g. 2ms, 0.5ms, 1s)")
    ms = float(match.group(1)) * _UNIT_MS[match.group(2)]
    if not math.isfinite(ms) or ms > most:
        raise FaultSpecError(f"{key}={value}: at most {most:g} ms")
    return ms


def _burst(value: str) -> Burst:
    count, at, when = value.partition("@")
    usage = f"burst={value}: expected N@T (e.g. 20@5s: 20 cycles lost from 5 s of simulated time)"
    if not at or not count.strip().isascii() or not count.strip().isdigit():
        raise FaultSpecError(usage)
    cycles = int(count)
    if not 1 <= cycles <= MAX_BURST_CYCLES:
        raise FaultSpecError(f"burst={value}: 1 to {MAX_BURST_CYCLES} cycles")
    match = _DURATION.match(when)
    if match is None:
        raise FaultSpecError(usage)
    ms = float(match.group(1)) * (1000.0 if match.group(2) in (None, "s") else
                                  _UNIT_MS[match.group(2)])
    if not math.isfinite(ms) or abs(ms - round(ms)) > 1e-6 or round(ms) >= 2**62:
        raise FaultSpecError(f"burst={value}: the start is a whole ms of simulated time")
    return Burst(round(ms), cycles)
