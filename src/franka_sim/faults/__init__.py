"""Network faults on purpose: loss, delay, jitter, bursts and reordering on a robot's UDP path,
each datagram's fate a pure function of (seed, robot, direction, message_id)
(docs/robustness.md). Sans-IO: server/network_faults.py wires the links into the endpoints and
the world's clock while a plan is set.

spec.py     the spec (`loss=0.01,delay=2ms`) and its parser
plan.py     each datagram's fate
link.py     one robot's path: what is held, what goes now
"""

from franka_sim.faults.plan import COMMANDS, STATES, FaultPlan, check_seed
from franka_sim.faults.spec import Burst, FaultSpec, FaultSpecError, parse_spec, spec_from_fields

__all__ = ["COMMANDS", "STATES", "Burst", "FaultPlan", "FaultSpec", "FaultSpecError",
           "check_seed", "parse_spec", "spec_from_fields"]
