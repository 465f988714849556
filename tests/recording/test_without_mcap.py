"""mcap is an extra: without it, every command that records or reads a recording says what to
install on one line, and a server that records nothing runs as ever."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import franka_sim
from franka_sim.recording import MCAP_HINT
from franka_sim.testing import fresh_loopback_address


@pytest.fixture
def without_mcap(tmp_path):
    """An environment in which `import mcap` fails, as where it is not installed."""
    fake = tmp_path / "mcap"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('no mcap here')\n")
    package_root = Path(franka_sim.__file__).resolve().parents[1]  # where franka_sim is
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(package_root)]))


def run(env, *args, timeout=60):
    return subprocess.run([sys.executable, "-m", "franka_sim", *args], env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("command,extra", [
    (["replay", "run.mcap"], "record"), (["plot", "run.mcap", "-o", "x.png"], "plot"),
    (["render", "run.mcap", "-o", "x.mp4"], "render"), (["view", "run.mcap"], "web")])
def test_readers_say_what_to_install(without_mcap, command, extra):
    """Each names the extra the command needs, which brings mcap with it (one install, not
    [record] and then [plot])."""
    done = run(without_mcap, *command)
    assert done.returncode == 1
    assert done.stderr.strip() == "franka-sim: " + MCAP_HINT.replace("[record]", f"[{extra}]")


def test_each_reading_extra_brings_mcap():
    import tomllib

    extras = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml")
                           .read_text())["project"]["optional-dependencies"]
    for extra in ("record", "plot", "render", "web"):
        assert any(need.startswith("mcap") for need in extras[extra]), extra


def test_serve_record_says_what_to_install(without_mcap, tmp_path):
    done = run(without_mcap, "serve", "--host", fresh_loopback_address(), "--record",
               str(tmp_path / "run.mcap"))
    assert done.returncode != 0
    assert "pip install 'franka-sim[record]'" in " ".join(done.stderr.replace("│", " ").split())
