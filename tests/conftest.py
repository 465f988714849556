"""Shared fixtures: a live simulated robot per test, each on its own loopback address.

The simulator runs as a real `franka-sim serve` subprocess (franka_sim.testing.ServerProcess)
on an address of its own, so tests do not collide with each other, with a concurrent pytest
run, or with a `franka-sim serve` left on the default.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from franka_sim.testing import running_sim

from capabilities import capability_of

TESTS = __import__("pathlib").Path(__file__).resolve().parent


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
