"""Network faults on purpose: loss, delay, jitter, bursts and reordering on a robot's UDP path,
each datagram's fate a pure function of (seed, robot, direction, message_id)
(docs/robustness.md). Sans-IO: server/network_faults.py wires the links into the endpoints and
the world's clock while a plan is set.

spec.py     the spec (`loss=0.01,delay=2ms`) and its parser
seed.py     the seed's range
plan.py     each datagram's fate
link.py     one robot's path: what is held, what goes now

The names below are imported on first use: a server that never injects a fault loads only
seed.py (to check its --seed).
"""

import importlib

_HOMES = {"COMMANDS": "plan", "STATES": "plan", "FaultPlan": "plan", "check_seed": "seed",
          "ArmLink": "link", "Burst": "spec", "FaultSpec": "spec", "FaultSpecError": "spec",
          "parse_spec": "spec", "spec_from_fields": "spec"}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
