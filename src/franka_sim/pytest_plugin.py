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

Each test's run is recorded (docs/recording.md) from that reset on, into
`franka-sim-recordings/<test id>.mcap` under the rootdir; `--franka-sim-record` keeps the
recordings of failed tests (the default), of all, or records none. A kept recording's path is
in the test's report (a section of a failure, the `franka_sim_recording` user property) and in
the terminal summary; `franka-sim replay PATH` re-runs it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from franka_sim.config import ROBOTS  # plain data: no numpy, no MuJoCo
from franka_sim.plugin_recordings import (  # noqa: F401 (PROPERTY, recording_name: API)
    PROPERTY, _KeptRecordings, _Recording, _recording_path, _recordings_dir, recording_name,
)

MARKER = "franka_sim"
_MARKER_FIELDS = {"clock": str, "scene": (str, os.PathLike), "enforce_motion_limits": bool,
                  "enforce_comm_constraints": bool, "gripper": bool, "desk_boot": str,
                  "robot": str, "faults": (str, dict)}
_CLOCKS = ("lockstep", "realtime")
_DESK_BOOTS = ("ready", "locked")
_HANDLE = pytest.StashKey["SimHandle"]()
_RECORD_MODES = ("failed", "all", "none")
_RECORDING = pytest.StashKey["_Recording"]()


class SimHandle:
    """What a test gets: the robot's address (FCI on 1337, Hand on 1338), its control API, and
    the server's log lines since this test began."""

    def __init__(self, server, control, settings, faults=None) -> None:
        self.host: str = server.host
        self.control = control  # franka_sim.control.Control
        self.settings = settings  # franka_sim.testing.server_pool.SimSettings
        self.server = server  # franka_sim.testing.ServerProcess: pid, the whole log
        self._log_start = len(server.sync())
        self._log_end: int | None = None  # where the test ended (the fixture's teardown)
        self.recording: Path | None = None  # this test's recording, while it is made
        self.faults: str | dict | None = faults  # the marker's, injected after the reset

    @property
    def desk(self) -> str | None:
        """HOST:PORT of its Desk (served when the marker says `desk_boot="locked"`), for
        franky.Desk and the other Desk clients; None: not served."""
        from franka_sim.testing.server_pool import DESK_PORT

        return f"{self.host}:{DESK_PORT}" if self.settings.desk_boot != "ready" else None

    @property
    def log(self) -> list[str]:
        from franka_sim.testing.server_pool import at_level, shown_level

        return at_level(self.server.sync()[self._log_start:self._log_end],
                        shown_level(os.environ))

    def ended(self) -> None:
        """The test is over: lines after are the next test's, or the session's end."""
        self._log_end = len(self.server.sync())

    def __repr__(self) -> str:
        faults = f" faults={self.faults!r}" if self.faults is not None else ""
        return f"<franka_sim at {self.host} {self.settings}{faults}>"


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
    group.addoption(
        "--franka-sim-record", choices=_RECORD_MODES, default="failed",
        help="record each test's run (MCAP, `franka-sim replay` re-runs it) and keep the "
        "recordings of failed tests (default), of all tests, or record none")
    group.addoption(
        "--franka-sim-record-dir", metavar="DIR", default=None,
        help="where the recordings go (default: franka-sim-recordings/ under the rootdir); "
        "relative to the directory pytest is run from")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        f"{MARKER}(enforce_motion_limits=False, enforce_comm_constraints=False, gripper=True, "
        "scene=None, clock=None, desk_boot='ready', robot='fr3', faults=None): the franka_sim "
        "fixture of this test is a simulator of this configuration (started on demand, shared "
        "by the tests that ask for the same), with these network faults on its UDP path")
    kept = _KeptRecordings()
    if config.getoption("--franka-sim-record") != "none" and not hasattr(config, "workerinput"):
        kept.directory = _recordings_dir(config)  # (the xdist controller's, not each worker's)
        kept.made = not kept.directory.exists()
    config.pluginmanager.register(kept, "franka-sim-recordings")
    directory = config.getoption("--franka-sim-record-dir")
    if directory is not None and config.getoption("--franka-sim-record") != "none":
        # Said once here, not as every test's setup error; made by the first recording (a
        # --collect-only run, or one whose tests use no simulator, leaves nothing behind).
        problem = _not_makeable(Path(config.invocation_params.dir, directory))
        if problem is not None:
            raise pytest.UsageError(f"--franka-sim-record-dir {directory}: {problem}")


def _not_makeable(path: Path) -> str | None:
    """Why `path` cannot be a directory recordings are written to (None: it is one, or
    `mkdir -p` would make one)."""
    if path.exists():
        if not path.is_dir():
            return "not a directory"
        writable = os.access(path, os.W_OK | os.X_OK)
        return None if writable else "cannot be written (Permission denied)"
    parent = path.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        return "cannot be made (Not a directory)"
    if not os.access(parent, os.W_OK | os.X_OK):
        return "cannot be made (Permission denied)"
    return None


@pytest.fixture(scope="session")
def franka_sim_servers():
    """This worker's simulators, stopped when the session ends."""
    from franka_sim.testing.server_pool import ServerPool

    pool = ServerPool(os.environ.get("PYTEST_XDIST_WORKER"), os.getpid())
    yield pool
    pool.stop_all()


@pytest.fixture
def franka_sim(request: pytest.FixtureRequest, franka_sim_servers):
    """A simulated FR3 + Franka Hand in the start world: arm at rest in the start pose, no
    errors, objects in place, Hand open, no client connected. Recorded from there on unless
    `--franka-sim-record none`."""
    settings, faults = _settings(request)
    path = _recording_path(request.node)
    try:
        server, control = franka_sim_servers.prepared(
            settings, None if path is None else str(path))
    except RuntimeError as exc:
        failure = str(exc)
    else:
        failure = None if faults is None else _inject(control, faults)
        if failure is not None and path is not None:  # no test ran: no recording of it
            _discard_recording(control, path)
    if failure is not None:  # failed outside the except: the report shows no chained error
        pytest.fail(failure, pytrace=False)
    handle = SimHandle(server, control, settings, faults)
    request.node.stash[_HANDLE] = handle
    if path is not None:
        handle.recording = path
        request.node.stash[_RECORDING] = _Recording(path)
    yield handle
    died = _died(server)
    handle.ended()
    if path is not None and died is None:
        from franka_sim.control import ControlError

        try:
            control.finish_recording()
        except ControlError as exc:
            request.node.stash[_RECORDING].trouble = f"not finished: {exc}"
    if died is not None:  # the test's own outcome aside, the robot it ran against is gone
        if path is not None:
            request.node.stash[_RECORDING].trouble = "not finished: the simulator died"
        pytest.fail(f"the simulator at {server.host} died during the test ({died}); "
                    f"the next test gets a fresh one", pytrace=False)


def _died(server) -> str | None:
    """How the test's server ended, if it did (None: it still serves)."""
    code = server.proc.poll()
    if code is None:
        return None
    return f"killed by signal {-code}" if code < 0 else f"exit status {code}"


def _discard_recording(control, path: Path) -> None:
    from franka_sim.control import ControlError

    try:
        control.finish_recording()
    except ControlError:
        pass
    path.unlink(missing_ok=True)


def _settings(request: pytest.FixtureRequest):
    from franka_sim.testing.server_pool import SimSettings

    config = request.config
    values = {"clock": config.getoption("--franka-sim-clock"),
              "scene": _absolute(config.getoption("--franka-sim-scene"),
                                 config.invocation_params.dir)}
    # Farthest first, so a function's marker overrides its class's and module's.
    for marker in reversed(list(request.node.iter_markers(MARKER))):
        values.update(_marker_values(marker, Path(request.node.path).parent))
    faults = values.pop("faults", None)  # set per test: tests with other faults share a server
    return SimSettings(**values), faults


def _inject(control, faults: str | dict) -> str | None:
    """Inject the marker's faults (`--inject`'s spec, or its fields as a dict with an optional
    seed) after the reset; the reason they were refused, if they were."""
    from franka_sim.control import BadRequest
    from franka_sim.control.table import FAULT_FIELDS

    said = f"@pytest.mark.{MARKER}: faults={faults!r} is not valid"
    if isinstance(faults, dict) and (unknown := sorted(set(faults) - set(FAULT_FIELDS))):
        return f"{said}: unknown field {unknown[0]!r} (known: {', '.join(FAULT_FIELDS)})"
    try:
        if isinstance(faults, str):
            control.set_faults(faults)
        else:
            control.set_faults(**faults)
    except BadRequest as exc:
        return f"{said}: {exc.message}"
    return None


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
        if value is None and name == "faults":
            values[name] = None  # none for this test, whatever a farther marker said
            continue
        choices = {"clock": _CLOCKS, "desk_boot": _DESK_BOOTS, "robot": ROBOTS}.get(name)
        if not isinstance(value, expected) or (choices is not None and value not in choices):
            valid = (f" (one of {', '.join(map(repr, choices))})" if choices is not None
                     else f" (a {' or '.join(t.__name__ for t in _types(expected))})")
            pytest.fail(f"@pytest.mark.{MARKER}: {name}={value!r} is not valid{valid}",
                        pytrace=False)
        values[name] = _absolute(value, test_dir) if name == "scene" else value
    return values


def _types(expected) -> tuple:
    return expected if isinstance(expected, tuple) else (expected,)


def _absolute(path, base: Path) -> str | None:
    """A scene file relative to `base`, made absolute; a bare name with no such file is a
    packaged scene's (`serve --scene` says so if it is neither)."""
    if path is None:
        return None
    file = (Path(base) / Path(path)).resolve()
    bare = isinstance(path, str) and Path(path).name == path and not Path(path).suffix
    return path if bare and not file.is_file() else str(file)  # (a folder is no scene)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """A failing test's report shows what the robot logged during it and where its recording
    is; once the test is torn down its recording is kept or removed."""
    outcome = yield
    report = outcome.get_result()
    handle = item.stash.get(_HANDLE, None)
    if handle is not None and report.failed:
        lines = _settled_log(handle)
        report.sections.append((f"franka-sim log ({handle.host})",
                                "\n".join(lines) if lines else "(no lines)"))
    recording = item.stash.get(_RECORDING, None)
    if recording is None:
        return
    if report.failed:
        recording.failed = True
        if not recording.named:  # the first failing phase's report (setup, call or teardown)
            recording.named = True
            report.sections.append(("franka-sim recording",
                                    f"{recording.path}\n(franka-sim replay {recording.path})"))
    if report.when == "teardown":
        item.config.pluginmanager.get_plugin("franka-sim-recordings").started.pop(
            recording.path, None)
        keep = recording.failed or item.config.getoption("--franka-sim-record") == "all"
        if keep and recording.path.exists():
            report.user_properties.append((PROPERTY, str(recording.path)))
            if recording.trouble:
                report.sections.append(("franka-sim recording", recording.trouble))
        else:
            recording.path.unlink(missing_ok=True)


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
