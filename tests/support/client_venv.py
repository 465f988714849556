"""A client package that cannot share the suite's environment (an older franky is the same
package as franky 2.0.0; panda-python bundles its own libfranka), installed from PyPI into a
virtual environment of its own."""

from __future__ import annotations

import subprocess
import venv
from pathlib import Path

import pytest


def client_python(requirement: str, where: Path) -> Path:
    """The python of a new virtual environment at `where` holding `requirement`; the test
    skips when no package registry is within reach."""
    venv.EnvBuilder(with_pip=True).create(where)
    python = where / "bin" / "python"
    done = subprocess.run([str(python), "-m", "pip", "install", "--quiet", requirement],
                          capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        pytest.skip(f"pip could not install {requirement}: {done.stderr.strip()[-300:]}")
    return python
