"""Network faults on purpose: loss, delay, jitter, bursts and reordering on a robot's UDP path,
each datagram's fate a pure function of (seed, arm, direction, message_id) (docs/robustness.md).

spec.py     the spec (`loss=0.01,delay=2ms`) and its parser
plan.py     each datagram's fate
link.py     one arm's path: what is held, what goes now (sans-IO)
network.py  the links of a world, wired into the endpoints and the driver while a plan is set
"""

from franka_sim.server.faults.network import NetworkFaults
from franka_sim.server.faults.plan import COMMANDS, STATES, FaultPlan, check_seed
from franka_sim.server.faults.spec import (Burst, FaultSpec, FaultSpecError, parse_spec,
                                          spec_from_fields)

__all__ = ["COMMANDS", "STATES", "Burst", "FaultPlan", "FaultSpec", "FaultSpecError",
           "NetworkFaults", "check_seed", "parse_spec", "spec_from_fields"]
