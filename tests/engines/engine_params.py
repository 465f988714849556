"""The physics engines the same client programs run on: a parameter per engine, the Genesis one
marked `genesis` and skipped, saying why, where the extra is not installed."""

from __future__ import annotations

import sys

import pytest

from franka_sim.physics.genesis.runtime import genesis_missing
from franka_sim.testing import ServerProcess, fresh_loopback_address

GENESIS_MISSING = genesis_missing()
# s for a server to serve: Genesis compiles its kernels at a machine's first start, niced, while
# the other worker runs (over 180 s on a busy two-core machine)
START_TIMEOUT = 900.0
ENGINES = [
    pytest.param("mujoco", id="mujoco"),
    pytest.param("genesis", id="genesis", marks=[
        pytest.mark.genesis,
        pytest.mark.skipif(GENESIS_MISSING is not None,
                           reason=f"genesis is not importable ({GENESIS_MISSING})")]),
]


def engine_server(engine: str, *args: str) -> ServerProcess:
    """A lockstep server on `engine`, serving. Genesis's goes niced: its kernels (compiled at a
    machine's first start, run on every core) would otherwise take the two cores from the
    suite's other worker, whose realtime tests then miss their timeouts."""
    command = None
    host = fresh_loopback_address()
    if engine == "genesis":
        command = ["nice", "-n", "10", sys.executable, "-m", "franka_sim", "serve", "--host",
                   host, "--clock", "lockstep", "--physics", engine, *args]
    return ServerProcess(host, "--clock", "lockstep", "--physics", engine, *args,
                         command=command).wait_ready(START_TIMEOUT)
