"""The matrix follows the real `serve` command: every option is a factor or classified, a new
switch joins by itself, every packaged scene is a world, and the runs cover every pair."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from combinations import factors as factors_module
from combinations.factors import (INJECT, NOT_FACTORS, WORLD_FLAGS, WORLDS, Unclassified,
                                  factors, serve_options)
from combinations.matrix import runs, uncovered_pairs
from franka_sim.physics.scene import packaged_scenes


def test_every_serve_option_is_a_factor_of_the_matrix_or_classified():
    covered = {flag for factor in factors() for flag in factor.flags}  # raises Unclassified
    options = {param.name for param in serve_options()}
    assert covered | set(NOT_FACTORS) == options
    assert not covered & set(NOT_FACTORS)


def test_the_hand_mapped_names_are_options_of_serve():
    # A renamed or removed option must not linger in the tables as a stale name.
    options = {param.name for param in serve_options()}
    assert set(NOT_FACTORS) | set(WORLD_FLAGS) | set(INJECT) | {"record"} <= options


def test_a_new_switch_joins_the_matrix_and_a_new_free_option_must_be_classified(monkeypatch):
    switch = SimpleNamespace(name="new_switch", opts=["--new-switch"], is_flag=True,
                             default=False)
    monkeypatch.setattr(factors_module, "serve_options", lambda: [*serve_options(), switch])
    joined = {factor.name: factor for factor in factors()}["new_switch"]
    assert joined.levels == (False, True)
    assert joined.args(True, None) == ("--new-switch",) and joined.args(False, None) == ()

    free = SimpleNamespace(name="new_path", opts=["--new-path"], is_flag=False, default=None)
    monkeypatch.setattr(factors_module, "serve_options", lambda: [*serve_options(), free])
    with pytest.raises(Unclassified, match="new_path"):
        factors()


def test_the_clock_levels_are_the_clis_choices():
    clock = {factor.name: factor for factor in factors()}["clock"]
    assert clock.levels == ("realtime", "lockstep")
    assert clock.args("lockstep", None) == ("--clock", "lockstep")


def test_every_packaged_scene_is_a_world_of_the_matrix():
    assert set(WORLDS) == set(packaged_scenes())


def test_the_runs_cover_every_pair_of_levels_and_set_every_factor():
    of = factors()
    chosen = runs(of)
    assert uncovered_pairs(of, chosen) == []
    names = [factor.name for factor in of]
    for run in chosen:
        assert list(run) == names
    assert len({tuple(run.values()) for run in chosen}) == len(chosen)  # no run twice
