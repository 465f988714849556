"""The shared fuzz generators (franka_sim.testing.fuzz_inputs) driven by hypothesis: every
choice is a draw, so a failure shrinks to its smallest input."""

from __future__ import annotations

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

# Modest, so the property tests cost seconds: benchmarks/fuzz.py is the long run.
FUZZ = settings(max_examples=80, deadline=None, derandomize=False,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


class DrawChooser:
    """A Chooser whose choices hypothesis draws."""

    def __init__(self, data: st.DataObject) -> None:
        self._draw = data.draw

    def integer(self, low: int, high: int) -> int:
        return self._draw(st.integers(low, high))

    def raw(self, max_size: int) -> bytes:
        return self._draw(st.binary(max_size=max_size))
