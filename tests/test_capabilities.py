"""Every test module is under exactly one capability (tests/capabilities.py)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from capabilities import CAPABILITIES, MODULES

HERE = Path(__file__).resolve().parent
USER_PROJECTS = ("plugin/project/", "plugin/recording_project/")  # run by the plugin's tests


def test_every_test_module_has_one_capability():
    found = {p.relative_to(HERE).as_posix() for p in HERE.rglob("test_*.py")}
    found = {m for m in found if not m.startswith(USER_PROJECTS) and "/" in m}
    named = Counter(m for modules in MODULES.values() for m in modules)
    assert sorted(found - set(named)) == [], "test modules under no capability"
    assert sorted(set(named) - found) == [], "capabilities name modules that do not exist"
    assert [m for m, n in named.items() if n > 1] == [], "modules under two capabilities"
    assert set(MODULES) == set(CAPABILITIES)


def test_every_capability_is_a_registered_marker():
    import tomllib

    config = tomllib.loads((HERE.parent / "pyproject.toml").read_text())
    markers = {m.split(":")[0] for m in config["tool"]["pytest"]["ini_options"]["markers"]}
    assert set(CAPABILITIES) <= markers
