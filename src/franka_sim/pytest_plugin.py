"""pytest plugin: the `franka_sim` fixture, a simulated FR3 + Franka Hand for each test.

Registered through the `pytest11` entry point, so installing franka-sim is enough. Every pytest
session loads this module, fixture used or not: it imports nothing heavy until a test asks for
a simulator.

    def test_reaches_target(franka_sim):
        robot = pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore)
        ...
        assert franka_sim.control.state()["robot_mode"] == "Idle"

Each pytest worker (xdist-safe) runs one `franka-sim serve` per configuration on loopback
addresses of its own, started on first use and reset through the control API before every
test; a failing test's report carries the server's log lines from that test.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

MARKER = "franka_sim"
_MARKER_FIELDS = {"clock": str, "scene": (str, os.PathLike), "enforce_motion_limits": bool,
                  "enforce_comm_constraints": bool, "gripper": bool}
_CLOCKS = ("lockstep", "realtime")
_HANDLE = pytest.StashKey["SimHandle"]()


class SimHandle:
    """What a test gets: the robot's address (FCI on 1337, Hand on 1338), its control API, and
    the server's log lines since this test began."""

    def __init__(self, server, control, settings) -> None:
        self.host: str = server.host
        self.control = control  # franka_sim.control.Control
        self.settings = settings  # franka_sim.testing.server_pool.SimSettings
        self.server = server  # franka_sim.testing.ServerProcess: pid, the whole log
        self._log_start = len(server.lines)

    @property
    def log(self) -> list[str]:
        return self.server.lines[self._log_start:]

    def __repr__(self) -> str:
        return f"<franka_sim at {self.host} {self.settings}>"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("franka-sim", "simulated Franka FR3 (the franka_sim fixture)")
    group.addoption(
        "--franka-sim-clock", choices=_CLOCKS, default="lockstep",
        help="clock of the franka_sim fixture's simulators (default lockstep: as fast as the "
        "client, independent of the machine's load; realtime: one cycle per wall-clock ms)")
    group.addoption(
        "--franka-sim-scene", metavar="PATH", default=None,
        help="MJCF scene of the franka_sim fixture's simulators (default: the packaged table "
        "and cube); relative to the directory pytest is run from")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        f"{MARKER}(enforce_motion_limits=False, enforce_comm_constraints=False, gripper=True, "
        "scene=None, clock=None): the franka_sim fixture of this test is a simulator of this "
        "configuration (started on demand, shared by the tests that ask for the same)")


@pytest.fixture(scope="session")
def franka_sim_servers():
    """This worker's simulators, stopped when the session ends."""
    from franka_sim.testing.server_pool import ServerPool

    pool = ServerPool(os.environ.get("PYTEST_XDIST_WORKER"), os.getpid())
    yield pool
    pool.stop_all()


@pytest.fixture
def franka_sim(request: pytest.FixtureRequest, franka_sim_servers) -> SimHandle:
    """A simulated FR3 + Franka Hand in the start world: arm at rest in the start pose, no
    errors, objects in place, Hand open, no client connected."""
    settings = _settings(request)
    try:
        server, control = franka_sim_servers.prepared(settings)
    except RuntimeError as exc:
        failure = str(exc)
    else:
        failure = None
    if failure is not None:  # failed outside the except: the report shows no chained error
        pytest.fail(failure, pytrace=False)
    handle = SimHandle(server, control, settings)
    request.node.stash[_HANDLE] = handle
    return handle


def _settings(request: pytest.FixtureRequest):
    from franka_sim.testing.server_pool import SimSettings

    config = request.config
    values = {"clock": config.getoption("--franka-sim-clock"),
              "scene": _absolute(config.getoption("--franka-sim-scene"),
                                 config.invocation_params.dir)}
    # Farthest first, so a function's marker overrides its class's and module's.
    for marker in reversed(list(request.node.iter_markers(MARKER))):
        values.update(_marker_values(marker, Path(request.node.path).parent))
    return SimSettings(**values)


def _marker_values(marker: pytest.Mark, test_dir: Path) -> dict:
    """A marker's settings, checked; a relative scene is relative to the test's file."""
    if marker.args:
        pytest.fail(f"@pytest.mark.{MARKER} takes keyword arguments only", pytrace=False)
    values = {}
    for name, value in marker.kwargs.items():
        expected = _MARKER_FIELDS.get(name)
        if expected is None:
            pytest.fail(f"@pytest.mark.{MARKER}: unknown setting {name!r} (known: "
                        f"{', '.join(sorted(_MARKER_FIELDS))})", pytrace=False)
        if value is None and name in ("clock", "scene"):
            continue  # the command line's choice
        if not isinstance(value, expected) or (name == "clock" and value not in _CLOCKS):
            pytest.fail(f"@pytest.mark.{MARKER}: {name}={value!r} is not valid", pytrace=False)
        values[name] = _absolute(value, test_dir) if name == "scene" else value
    return values


def _absolute(path, base: Path) -> str | None:
    return None if path is None else str((Path(base) / Path(path)).resolve())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """A failing test's report shows what the robot logged during it."""
    outcome = yield
    report = outcome.get_result()
    handle = item.stash.get(_HANDLE, None)
    if handle is not None and report.failed:
        lines = _settled_log(handle)
        report.sections.append((f"franka-sim log ({handle.host})",
                                "\n".join(lines) if lines else "(no lines)"))


def _settled_log(handle: SimHandle, quiet: float = 0.05, limit: float = 0.5) -> list[str]:
    """The test's log once no new line came for `quiet` seconds: what the server logged as the
    test failed (an abort, a disconnect) is still in the pipe."""
    end = time.monotonic() + limit
    lines = handle.log
    while time.monotonic() < end:
        time.sleep(quiet)
        now = handle.log
        if len(now) == len(lines):
            break
        lines = now
    return lines
