"""The runs of the combination matrix: a pairwise covering set of the factors' levels.

Every level of every factor meets every level of every other factor in at least one run, which
takes far fewer runs than all combinations (`pytest tests/combinations` says how many in its
header). allpairspy builds the set; it draws nothing at random, so every process (each pytest-xdist
worker) collects the same runs in the same order.
"""

from __future__ import annotations

import itertools
from collections import OrderedDict

from allpairspy import AllPairs

from combinations.factors import Factor, factors


def runs(of: list[Factor] | None = None) -> list[dict]:
    """The runs, each a {factor name: level} for every factor."""
    of = factors() if of is None else of
    table = OrderedDict((factor.name, list(factor.levels)) for factor in of)
    return [dict(row._asdict()) for row in AllPairs(table)]


def uncovered_pairs(of: list[Factor], chosen: list[dict]) -> list[tuple]:
    """The pairs of levels of two factors that no run of `chosen` holds (empty: covering)."""
    seen = {(a, run[a], b, run[b]) for run in chosen
            for a, b in itertools.combinations(run, 2)}
    return [(a.name, x, b.name, y) for a, b in itertools.combinations(of, 2)
            for x in a.levels for y in b.levels if (a.name, x, b.name, y) not in seen]


def run_id(run: dict) -> str:
    """A test id naming what a run switches on: `lockstep-mobile_duo+record+push`."""
    words = [str(level) for level in run.values() if not isinstance(level, bool)]
    switched = [name for name, level in run.items() if level is True]
    return "-".join(words) + "".join(f"+{name}" for name in switched)
