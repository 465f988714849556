"""The plugin's recordings as a user meets them: a project of their own
(tests/plugin/recording_project) run by pytest in a subprocess with each --franka-sim-record
choice; what is kept replays identical in a fresh simulator."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from franka_sim.pytest_plugin import PROPERTY, recording_name

PROJECT = Path(__file__).with_name("recording_project")
PASSING = "test_recorded.py::test_changes_the_world_and_passes"
FAILING = "test_recorded.py::test_moves_then_fails"


def _run_project(tmp_path: Path, *args: str) -> tuple[Path, str]:
    """pytest on a copy of the project: (its directory, the output)."""
    project = tmp_path / "project"
    shutil.copytree(PROJECT, project)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q",
         "--junitxml=report.xml", *args],
        cwd=project, env=env, capture_output=True, text=True, timeout=600)
    output = done.stdout + done.stderr
    assert done.returncode == 1, output
    assert "1 failed, 1 passed" in output.strip().splitlines()[-1], output
    return project, output


def _replay(path: Path) -> str:
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout.strip()


def _properties(project: Path) -> dict[str, str]:
    cases = ET.parse(project / "report.xml").getroot().iter("testcase")
    return {case.get("name"): prop.get("value") for case in cases
            for prop in case.iter("property") if prop.get("name") == PROPERTY}


def test_by_default_a_failed_test_leaves_a_recording_that_replays_identical(tmp_path):
    project, output = _run_project(tmp_path)
    directory = project / "franka-sim-recordings"
    path = directory / recording_name(FAILING)
    assert sorted(directory.iterdir()) == [path]
    assert "franka-sim recordings" in output and f"{FAILING}: {path}" in output
    failure = output.split("franka-sim recording ---", 1)[1]  # the failure's own section
    assert str(path) in failure.split("\n", 2)[1]
    assert _properties(project) == {"test_moves_then_fails": str(path)}
    assert _replay(path).startswith("identical (")


def test_all_keeps_every_test_s_recording_and_none_records_none(tmp_path):
    project, output = _run_project(tmp_path / "all", "--franka-sim-record", "all",
                                   "--franka-sim-record-dir", "runs")
    kept = sorted((project / "runs").iterdir())
    assert kept == sorted(project / "runs" / recording_name(n) for n in (PASSING, FAILING))
    assert not (project / "franka-sim-recordings").exists()
    for path in kept:
        assert f": {path}" in output
        assert _replay(path).startswith("identical (")

    project, output = _run_project(tmp_path / "none", "--franka-sim-record", "none")
    assert not (project / "franka-sim-recordings").exists()
    assert "franka-sim recordings" not in output and _properties(project) == {}


@pytest.mark.parametrize("nodeid, name", [
    ("tests/test_a.py::test_b", "tests__test_a.py__test_b.mcap"),
    ("t.py::C::test[1-x y/z]", "t.py__C__test_1-x_y__z_-d151c072.mcap"),
])
def test_a_recording_is_named_after_its_test(nodeid, name):
    assert recording_name(nodeid) == name
    long = recording_name("t.py::test[" + "x" * 300 + "]")
    assert len(long) < 160 and long != recording_name("t.py::test[" + "x" * 299 + "]")
    # ids the replacement alone would give one name keep one recording each
    assert recording_name("t.py::test[a:b]") != recording_name("t.py::test[a;b]")


@pytest.mark.parametrize("directory, said", [
    ("runs", "--franka-sim-record-dir runs: not a directory"),
    ("runs/sub", "--franka-sim-record-dir runs/sub: cannot be made (Not a directory)")])
def test_a_recording_directory_that_cannot_be_one_is_one_usage_error(tmp_path, directory, said):
    project = tmp_path / "project"
    shutil.copytree(PROJECT, project)
    (project / "runs").write_text("not a directory")
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q",
         "--franka-sim-record-dir", directory], cwd=project, capture_output=True, text=True,
        env={k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}, timeout=600)
    assert done.returncode == 4  # pytest's usage error: no test ran
    assert said in done.stderr
    assert "Traceback" not in done.stdout + done.stderr


def test_a_recording_directory_is_made_by_the_first_recording_only(tmp_path):
    """`--collect-only` (or a run whose tests use no simulator) leaves no directory behind."""
    project = tmp_path / "project"
    shutil.copytree(PROJECT, project)
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q",
         "--collect-only", "--franka-sim-record-dir", "runs/nested"], cwd=project,
        capture_output=True, text=True, timeout=600,
        env={k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")})
    assert done.returncode == 0, done.stdout + done.stderr
    assert not (project / "runs").exists()


CONCURRENT = '''
import os, time
from pathlib import Path

def test_recorded_while_another_run_records_it(franka_sim):
    flags = Path(os.environ["FLAGS"])
    (flags / os.environ["ME"]).write_text(str(franka_sim.recording))
    if os.environ["ME"] == "first":  # holds its recording open until the second run's test ran
        end = time.monotonic() + 120
        while not (flags / "second").exists() and time.monotonic() < end:
            time.sleep(0.05)
        assert (flags / "second").exists()
'''


def test_two_runs_of_one_project_at_once_record_a_test_each_to_its_own_file(tmp_path):
    """A second run whose test the first records at that moment records it beside, under a
    name of its own, instead of failing the test's setup; each replays."""
    project, flags = tmp_path / "project", tmp_path / "flags"
    project.mkdir()
    flags.mkdir()
    (project / "test_concurrent.py").write_text(CONCURRENT)
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    command = [sys.executable, "-m", "pytest", *([] if installed else
                                                 ["-p", "franka_sim.pytest_plugin"]),
               "-p", "no:cacheprovider", "-q", "--franka-sim-record", "all"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    env["FLAGS"] = str(flags)
    first = subprocess.Popen(command, cwd=project, env={**env, "ME": "first"},
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        end = time.monotonic() + 120
        while not (flags / "first").exists() and first.poll() is None:
            assert time.monotonic() < end, "the first run's test did not start"
            time.sleep(0.05)
        second = subprocess.run(command, cwd=project, env={**env, "ME": "second"},
                                capture_output=True, text=True, timeout=300)
        assert second.returncode == 0, second.stdout + second.stderr
    finally:
        out, _ = first.communicate(timeout=300)
    assert first.returncode == 0, out
    paths = [Path((flags / me).read_text()) for me in ("first", "second")]
    assert paths[0] != paths[1] and paths[0].parent == paths[1].parent
    assert sorted(paths[0].parent.iterdir()) == sorted(paths)
    for path in paths:
        assert _replay(path).startswith("identical (")


def test_a_run_whose_tests_all_pass_leaves_no_recordings_directory(tmp_path):
    """The directory the run made for its recordings goes again when none was kept; one that
    was there before stays."""
    project = tmp_path / "project"
    project.mkdir()
    (project / "test_passes.py").write_text(
        "def test_reads(franka_sim):\n    assert franka_sim.control.state()['q']\n")
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    command = [sys.executable, "-m", "pytest", *([] if installed else
                                                 ["-p", "franka_sim.pytest_plugin"]),
               "-p", "no:cacheprovider", "-q"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    for args in ([], ["-n", "2"]):
        done = subprocess.run(command + args, cwd=project, env=env, capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        assert not (project / "franka-sim-recordings").exists(), args
    (project / "franka-sim-recordings").mkdir()
    done = subprocess.run(command, cwd=project, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0 and (project / "franka-sim-recordings").is_dir()


def _run_module(tmp_path: Path, name: str, text: str, workers: int = 0):
    """pytest (no workers, or `workers` of pytest-xdist's, the run in a process group of its
    own) on a project of one test module: (its directory, the run)."""
    project = tmp_path / "project"
    project.mkdir()
    (project / name).write_text(text)
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    return project, subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q", "-n",
         str(workers)], cwd=project, capture_output=True, text=True, timeout=600,
        env={k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")},
        start_new_session=True)


FAILING_AROUND = '''
import os, signal, time

import pylibfranka
import pytest


def test_server_dies(franka_sim):
    pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore).read_once()
    os.kill(franka_sim.server.pid, signal.SIGKILL)  # as a crash would
    while franka_sim.server.proc.poll() is None:
        time.sleep(0.01)


@pytest.fixture
def breaks_after():
    yield
    raise RuntimeError("the user's own fixture fails in its teardown")


def test_teardown_fails(franka_sim, breaks_after):
    pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore).read_once()
'''


def test_a_simulator_that_died_and_a_teardown_that_failed_are_reported(tmp_path):
    """A test whose simulator died errors at teardown saying so (the test itself passed: its
    report alone would say nothing), its recording unfinished; a test whose own fixture fails
    at teardown names its recording there, and its log ends with the test (not with the
    session's server stopping after the last test)."""
    project, done = _run_module(tmp_path, "test_around.py", FAILING_AROUND)
    output = done.stdout + done.stderr
    assert done.returncode == 1 and "2 passed, 2 errors" in output, output
    died, teardown = output.split("ERROR at teardown of test_teardown_fails")
    died = died.split("ERROR at teardown of test_server_dies")[1]
    assert "died during the test (killed by signal 9)" in died
    assert "not finished: the simulator died" in died
    teardown = teardown.split("= short test summary")[0]
    path = project / "franka-sim-recordings" / recording_name("test_around.py::test_teardown_fails")
    assert f"franka-sim replay {path}" in teardown and path.exists()
    assert "stopping" not in teardown


INTERRUPTED = '''
import pylibfranka


def test_interrupted(franka_sim):
    pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore).read_once()
    raise KeyboardInterrupt  # as Ctrl-C in the middle of the test would
'''


def test_a_run_interrupted_mid_test_lists_the_recording_it_leaves(tmp_path):
    project, done = _run_module(tmp_path, "test_interrupted.py", INTERRUPTED)
    output = done.stdout + done.stderr
    path = project / "franka-sim-recordings" / recording_name(
        "test_interrupted.py::test_interrupted")
    assert done.returncode == 2 and path.exists(), output  # pytest's: interrupted
    assert (f"test_interrupted.py::test_interrupted: {path} (interrupted: kept as far as it "
            "was written)") in output


INTERRUPTED_ON_A_WORKER = '''
import os, signal, time

import pylibfranka


def test_interrupted(franka_sim):
    pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore).read_once()
    os.killpg(os.getpgid(0), signal.SIGINT)  # Ctrl-C: every process of the run
    time.sleep(60)
'''


def test_a_run_on_workers_interrupted_mid_test_lists_the_recording_it_leaves(tmp_path):
    """pytest-xdist: the worker's own summary is not shown; the run's lists what it left."""
    project, done = _run_module(tmp_path, "test_interrupted.py", INTERRUPTED_ON_A_WORKER,
                                workers=1)
    output = done.stdout + done.stderr
    path = project / "franka-sim-recordings" / recording_name(
        "test_interrupted.py::test_interrupted")
    assert done.returncode == 2 and path.exists(), output
    assert f"a worker's test: {path} (interrupted: kept as far as it was written)" in output
