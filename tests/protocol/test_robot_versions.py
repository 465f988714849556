"""The older robot protocols by version (protocol/robot_versions.py): each version's module is
named there without importing it, and is the module of that version."""

from __future__ import annotations

import importlib

from franka_sim.protocol.robot_versions import DIALECTS, MODULES


def test_each_older_version_is_served_by_the_module_that_says_it_is_that_version():
    assert sorted(DIALECTS) == [5, 6, 7, 8, 9] and len(DIALECTS) == 5
    for version, name in MODULES.items():
        module = importlib.import_module(f"franka_sim.protocol.{name}")
        assert module.VERSION == version
        assert DIALECTS[version] is module.Dialect
        assert DIALECTS.get(version) is module.Dialect
    assert DIALECTS.get(10) is None and 4 not in DIALECTS
