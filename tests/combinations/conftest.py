"""The combination matrix's fixtures: an X server for the runs that open the viewer."""

from __future__ import annotations

import math

import pytest

from combinations.factors import factors
from combinations.matrix import runs
from support.client_venv import client_python
from support.xserver import opengl_display


def pytest_report_header(config):
    """How many runs the pairwise set takes (shown when this folder is run on its own)."""
    of = factors()
    everything = math.prod(len(factor.levels) for factor in of)
    return (f"combinations: {len(runs(of))} runs cover every pair of levels of {len(of)} "
            f"factors ({everything} combinations in all)")


@pytest.fixture(scope="session")
def x_display():
    """A DISPLAY for `serve --viewer`: one Xvfb for the whole test run, on which OpenGL
    windows are known to reach the screen."""
    with opengl_display() as display:
        yield display


@pytest.fixture(scope="session")
def panda_python(tmp_path_factory):
    """The python of an environment with panda-python 1.1.1, whose VacuumGripper drives the
    runs' pumps (pylibfranka 0.21 has no binding of it)."""
    return client_python("panda-python==1.1.1", tmp_path_factory.mktemp("panda-python"))
