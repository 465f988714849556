"""docs/testing.md's worked example (examples/testing) passes as a user runs it: a copy of the
project on its own, `python -m pytest -n 2`, the plugin and nothing else."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "testing"


def test_the_worked_example_passes_on_two_workers(tmp_path):
    project = tmp_path / "project"
    shutil.copytree(EXAMPLE, project, ignore=shutil.ignore_patterns("__pycache__"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    # Installed, the package's pytest11 entry point loads the plugin; from a source tree whose
    # installed metadata predates it, load it by name.
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q", "-n", "2"],
        cwd=project, env=env, capture_output=True, text=True, timeout=600)
    output = done.stdout + done.stderr
    assert done.returncode == 0, output
    summary = output.strip().splitlines()[-1]
    assert re.search(r"\b4 passed\b", summary) and "failed" not in summary, output


def test_the_doc_shows_the_example_as_it_is():
    doc = (ROOT / "docs" / "testing.md").read_text()
    for name in ("my_controller.py", "test_my_controller.py"):
        shown = f"```python\n{(EXAMPLE / name).read_text()}```"
        assert shown in doc, f"docs/testing.md does not show examples/testing/{name} as it is"
