"""A served simulator with its control API, shared by the tests of one module (each test
resets it first), and the Control client for it."""

from __future__ import annotations

import pytest

from franka_sim.control import Control
from franka_sim.testing import running_sim


@pytest.fixture(scope="module")
def served():
    """`franka-sim serve` with the control API on its default port, for the whole module."""
    with running_sim("--control-port", "1340") as sim:
        yield sim


@pytest.fixture
def control(served) -> Control:
    """The Control client of `served`, after a reset: every test starts from the same world."""
    client = Control(served.host)
    client.reset()
    return client
