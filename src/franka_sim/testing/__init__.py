"""Helpers for testing and measuring a served robot from the outside: a `franka-sim serve`
subprocess and a raw v10 client; and, imported on their own, the fuzz generators and targets
(`fuzz_inputs`, `fuzz_targets`: they load MuJoCo) and `realtime_kernel` (a libfranka program
run as if the kernel were PREEMPT_RT). Shared by the test suite and the
benchmarks; nothing in the simulator imports them."""

from franka_sim.testing.raw_client import RawClient
from franka_sim.testing.server_process import ServerProcess, fresh_loopback_address, running_sim

__all__ = ["RawClient", "ServerProcess", "fresh_loopback_address", "running_sim"]
