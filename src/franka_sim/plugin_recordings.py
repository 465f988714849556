"""The pytest plugin's recordings: where each test's goes, and the run's list of those kept.

(pytest_plugin.py records each test from its reset on and decides, at teardown, what stays.)
"""

from __future__ import annotations

import hashlib
import os
import re
import time
from pathlib import Path

import pytest

PROPERTY = "franka_sim_recording"  # the user property naming a kept recording


class _Recording:
    """A test's recording: where, whether a phase of the test failed, and whether a report
    already named it."""

    def __init__(self, path: Path) -> None:
        self.path, self.failed, self.trouble = path, False, ""
        self.named = False


def _recording_path(item: pytest.Item) -> Path | None:
    """Where this test is recorded (None: `--franka-sim-record none`)."""
    config = item.config
    if config.getoption("--franka-sim-record") == "none":
        return None
    from franka_sim.recording import mcap_missing

    if missing := mcap_missing():  # said once, in the terminal summary
        config.pluginmanager.get_plugin("franka-sim-recordings").unavailable = missing
        return None
    directory = _recordings_dir(config)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory.resolve() / recording_name(item.nodeid)
    if _recorded_now(path):  # another run of this project records this test now
        path = path.with_name(f"{path.stem}-{os.getpid()}{path.suffix}")
    config.pluginmanager.get_plugin("franka-sim-recordings").started[path] = item.nodeid
    return path


def _recordings_dir(config: pytest.Config) -> Path:
    directory = config.getoption("--franka-sim-record-dir")
    return (Path(config.invocation_params.dir, directory) if directory is not None
            else Path(config.rootpath, "franka-sim-recordings"))


def _recorded_now(path: Path) -> bool:
    from franka_sim.recording import being_written

    try:
        with open(path, "rb") as stream:
            return being_written(stream)
    except FileNotFoundError:  # (the usual case)
        return False


def recording_name(nodeid: str) -> str:
    """A file name for a test id: path separators and `::` as `__`, anything else but
    letters, digits and `._=-` as `_`; where that replaced a character (`[a:b]` and `[a;b]`
    would share a name) or the id is long (cut short), a digest of the whole id follows."""
    plain = nodeid.replace("::", "__").replace("/", "__")
    name = re.sub(r"[^A-Za-z0-9._=-]", "_", plain)
    if name != plain or len(name) > 150:
        name = f"{name[:130]}-{hashlib.sha256(nodeid.encode()).hexdigest()[:8]}"
    return f"{name}.mcap"


class _KeptRecordings:
    """The recordings kept in this pytest run (from xdist workers too), for the summary."""

    SUMMARY_LINES = 50

    def __init__(self) -> None:
        self.kept: list[tuple[str, str]] = []
        self.directory: Path | None = None  # where they go, and whether this run made it
        self.made = False
        # Recordings begun and not yet kept or removed (this process's tests): at the summary,
        # those of a run interrupted mid-test (Ctrl-C), kept as far as they were written.
        self.started: dict[Path, str] = {}
        self.since = time.time()  # (an xdist worker's are found in the directory: `_left`)

    def _left(self, listed) -> list[Path]:
        """An interrupted run's recordings its workers (pytest-xdist) began and never kept nor
        removed: made in this run, not yet listed, not kept, and not being written (another
        run's)."""
        from franka_sim.recording import being_written

        known = {str(path) for _, path in listed} | {str(path) for _, path in self.kept}
        found = []
        directory = self.directory
        for path in sorted(directory.glob("*.mcap")) if directory is not None else ():
            try:
                if str(path) in known or path.stat().st_mtime < self.since:
                    continue
                with open(path, "rb") as stream:
                    if not being_written(stream):
                        found.append(path)
            except OSError:  # (removed meanwhile)
                continue
        return found

    def pytest_unconfigure(self, config: pytest.Config) -> None:
        """A directory this run made and kept nothing in goes again (every test passed)."""
        if self.made and self.directory is not None:
            try:
                self.directory.rmdir()
            except OSError:  # not there, or not empty (another run's recordings too)
                pass

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        if report.when == "teardown":
            self.kept += [(report.nodeid, value) for name, value in report.user_properties
                          if name == PROPERTY]

    unavailable: str | None = None  # why no test was recorded (mcap is not installed)

    def pytest_terminal_summary(self, terminalreporter, exitstatus) -> None:
        if self.unavailable is not None:
            terminalreporter.section("franka-sim recordings")
            terminalreporter.line(f"no test was recorded: {self.unavailable}")
        interrupted = [(nodeid, path) for path, nodeid in self.started.items() if path.exists()]
        if exitstatus == pytest.ExitCode.INTERRUPTED:
            interrupted += [("a worker's test", path) for path in self._left(interrupted)]
        if not self.kept and not interrupted:
            return
        terminalreporter.section("franka-sim recordings")
        for nodeid, path in interrupted:
            terminalreporter.line(f"{nodeid}: {path} (interrupted: kept as far as it was written)")
        for nodeid, path in self.kept[:self.SUMMARY_LINES]:
            terminalreporter.line(f"{nodeid}: {path}")
        if len(self.kept) > self.SUMMARY_LINES:
            terminalreporter.line(f"... and {len(self.kept) - self.SUMMARY_LINES} more in "
                                  f"{Path(self.kept[-1][1]).parent}")
        terminalreporter.line("(`franka-sim replay PATH` re-runs one, `franka-sim plot PATH "
                              "-o run.png` draws it)")
