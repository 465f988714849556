"""Choosing the physics engine: `serve --help` lists them; an engine whose extra is missing
says in one line what to install and the serve exits non-zero (Genesis is made unimportable
here when it is installed); an embedded Config meets the same rule; what Genesis does not
simulate is refused in one line."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from franka_sim.config import ArmSpec, Config
from franka_sim.config_rules import ConfigError, checked

# `franka-sim serve --physics genesis` in a process where `import genesis` finds nothing.
WITHOUT_GENESIS = ("import sys; sys.modules['genesis'] = None; "
                   "sys.argv = ['franka-sim', 'serve', '--physics', 'genesis', '--host', "
                   "'127.0.0.1']; from franka_sim.cli import main; main()")


def test_serve_help_lists_the_engines():
    help_text = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--help"],
                               capture_output=True, text=True, env={"COLUMNS": "200",
                                                                    "PATH": ""}).stdout
    assert "--physics" in help_text and "mujoco|genesis" in help_text
    assert "mujoco (default) or genesis" in help_text


def test_without_the_extra_genesis_says_in_one_line_what_to_install():
    done = subprocess.run([sys.executable, "-c", WITHOUT_GENESIS], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "pip install 'franka-sim[genesis]'" in lines[0]
    assert done.stdout == ""


def test_an_embedded_config_meets_the_same_rule(monkeypatch):
    monkeypatch.setitem(sys.modules, "genesis", None)
    with pytest.raises(ConfigError, match=r"pip install 'franka-sim\[genesis\]'") as raised:
        checked(Config(physics="genesis"))
    assert raised.value.flag == "--physics"
    with pytest.raises(ConfigError, match="not an engine"):
        checked(Config(physics="bullet"))
    assert checked(Config()).physics == "mujoco"


ONE_ARM = (ArmSpec("left", "127.0.0.2"),)
TWO_ARMS = ONE_ARM + (ArmSpec("right", "127.0.0.3", base=(0.0, 1.0, 0.0, 0.0)),)


@pytest.mark.parametrize("changes,refused", [
    (dict(arms=TWO_ARMS), "simulates one arm"),
    (dict(arms=ONE_ARM, mobile_base="127.0.0.4"), "simulates one arm"),
    (dict(tool="vacuum"), "carries the Franka Hand or no tool"),
    (dict(arms=(ArmSpec("left", "127.0.0.2", tool="vacuum"),)), "carries the Franka Hand"),
    (dict(web_port=8080), "without --web"),
    (dict(record=Path("run.mcap")), "without --record"),
    (dict(meshes=Path("franka_description")), "without --meshes"),
])
def test_genesis_refuses_what_it_does_not_simulate(monkeypatch, changes, refused):
    """What docs/engines.md lists as MuJoCo's alone, refused in one ConfigError (installed or
    not: the extra's check is made to pass)."""
    monkeypatch.setattr("franka_sim.physics.engine_choice.engine_missing", lambda name: None)
    with pytest.raises(ConfigError, match=refused) as raised:
        checked(Config(physics="genesis", **changes))
    assert raised.value.flag == "--physics"
    checked(Config(physics="genesis", arms=ONE_ARM))  # one arm on the world, the Hand: served


def test_a_world_genesis_cannot_simulate_is_said_before_its_missing_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "genesis", None)  # (not installed)
    with pytest.raises(ConfigError, match="simulates one arm"):
        checked(Config(physics="genesis", arms=TWO_ARMS))


def test_genesis_refuses_the_mujoco_viewer_at_the_command_line():
    """Before the viewer's own need of a display is said (none here): no display would
    serve it."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--physics", "genesis",
                           "--viewer", "--host", "127.0.0.1"], capture_output=True, text=True,
                          timeout=60, env=env)
    assert done.returncode != 0 and "MuJoCo's viewer shows the MuJoCo world only" in done.stderr
