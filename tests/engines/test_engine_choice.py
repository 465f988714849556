"""Choosing the physics engine: `serve --help` lists them; an engine whose extra is missing
says in one line what to install and the serve exits non-zero (Genesis is made unimportable
here when it is installed); an embedded Config meets the same rule."""

from __future__ import annotations

import subprocess
import sys

import pytest

from franka_sim.config import Config
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
