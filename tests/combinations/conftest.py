"""The combination matrix's fixtures: an X server for the runs that open the viewer."""

from __future__ import annotations

import math
import os
import shutil
import subprocess

import pytest

from combinations.factors import factors
from combinations.matrix import runs


def pytest_report_header(config):
    """How many runs the pairwise set takes (shown when this folder is run on its own)."""
    of = factors()
    everything = math.prod(len(factor.levels) for factor in of)
    return (f"combinations: {len(runs(of))} runs cover every pair of levels of {len(of)} "
            f"factors ({everything} combinations in all)")


@pytest.fixture(scope="session")
def x_display():
    """A DISPLAY for `serve --viewer`: an Xvfb of this session, on a display number it picks
    itself (-displayfd), so concurrent sessions and workers never collide."""
    if shutil.which("Xvfb") is None:
        pytest.skip("--viewer needs an X server and Xvfb is not installed "
                    "(apt-get install xvfb)")
    read, write = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1024x768x24",
                             "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    os.close(write)
    with os.fdopen(read) as told:
        number = told.readline().strip()  # written once it accepts clients; "" if it died
    if not number:
        xvfb.kill()
        raise RuntimeError(f"Xvfb did not start: {xvfb.communicate(timeout=10)[1]}")
    try:
        yield f":{number}"
    finally:
        xvfb.terminate()
        xvfb.wait(10)
