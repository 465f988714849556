"""Shared fixtures: a live simulated robot per test, each on its own loopback address.

The simulator runs as a real `franka-sim serve` subprocess (franka_sim.testing.ServerProcess)
on an address of its own, so tests do not collide with each other, with a concurrent pytest
run, or with a `franka-sim serve` left on the default.
"""

from __future__ import annotations

import faulthandler
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

from franka_sim.testing import running_sim

from capabilities import capability_of

TESTS = Path(__file__).resolve().parent
# A test still running after this long is hung: its process writes every thread's stack to a
# file of HUNG and exits (a C watchdog: pylibfranka waits for a reply holding the interpreter's
# lock, so nothing in Python could act), and the run goes on without it.
HUNG_AFTER = 600.0  # s; the slowest test takes ~70 s here
# One folder per run (the pid of the process that runs the session, the xdist workers'
# parent): another run's tests in progress on the same machine are no hung tests of this one.
HUNG = Path(tempfile.gettempdir()) / "franka-sim-hung-tests" / str(
    os.getppid() if "PYTEST_XDIST_WORKER" in os.environ else os.getpid())


def pytest_collection_modifyitems(items):
    """Each test marked with its module's capability (tests/capabilities.py): `-m limits`."""
    for item in items:
        try:
            module = item.path.relative_to(TESTS).as_posix()
        except ValueError:  # a user's project the plugin's tests run
            continue
        capability = capability_of(module)
        if capability is not None:
            item.add_marker(capability)


@pytest.fixture(autouse=True)
def _watchdog(request):
    HUNG.mkdir(parents=True, exist_ok=True)
    name = request.node.nodeid.replace("/", "_").replace("::", "__")[:150]
    with open(HUNG / f"{name}.{os.getpid()}.txt", "w") as dump:
        dump.write(f"{request.node.nodeid} ran for {HUNG_AFTER:.0f} s:\n")
        dump.flush()
        faulthandler.dump_traceback_later(HUNG_AFTER, exit=True, file=dump)
        try:
            yield
        finally:
            faulthandler.cancel_dump_traceback_later()
    os.unlink(dump.name)


def pytest_terminal_summary(terminalreporter):
    """The stacks of the tests the watchdog ended during this run."""
    for dump in sorted(HUNG.glob("*.txt")) if HUNG.is_dir() else ():
        terminalreporter.write_sep("=", f"hung: {dump.name}")
        terminalreporter.write_line(dump.read_text())


@pytest.fixture(autouse=True)
def _ordinary_scheduling():
    """libfranka raises the thread that starts a control loop to SCHED_FIFO 99 (as root it
    can), and every process the test process starts later inherits that: a build or a busy
    helper at the highest real-time priority starves a 2-core machine. Back to normal after
    each test."""
    yield
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError):
        pass


@pytest.fixture
def sim():
    with running_sim() as s:
        yield s


@pytest.fixture
def robot(sim):
    """A pylibfranka Robot connected to a fresh simulator, as client code would make it."""
    import pylibfranka

    return pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)


@pytest.fixture(scope="session")
def description():
    from franka_sim.description.urdf import default_urdf_text, load_arm_description

    return load_arm_description(default_urdf_text())


@pytest.fixture(scope="session")
def physics(description):
    """The simulator's own physics, built exactly as the server builds it, for comparisons."""
    from franka_sim.config import READY_POSE
    from franka_sim.physics.mujoco_backend import MujocoBackend

    return MujocoBackend(description, np.array(READY_POSE))
