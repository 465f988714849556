"""The physics engines the same client programs run on: a parameter per engine, the Genesis one
marked `genesis` and skipped, saying why, where the extra is not installed."""

from __future__ import annotations

import pytest

from franka_sim.physics.genesis.runtime import genesis_missing

GENESIS_MISSING = genesis_missing()
START_TIMEOUT = 180.0  # s for a server to serve: Genesis compiles its kernels at a first start
ENGINES = [
    pytest.param("mujoco", id="mujoco"),
    pytest.param("genesis", id="genesis", marks=[
        pytest.mark.genesis,
        pytest.mark.skipif(GENESIS_MISSING is not None,
                           reason=f"genesis is not importable ({GENESIS_MISSING})")]),
]
