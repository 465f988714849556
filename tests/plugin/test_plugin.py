"""The pytest plugin as a user meets it: a project of their own (tests/plugin/project) that uses
the `franka_sim` fixture and no conftest, run by pytest in a subprocess, serially and on two
xdist workers."""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import textwrap
import tomllib
from collections import defaultdict
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from franka_sim.pytest_plugin import recording_name
from franka_sim.testing.server_pool import DESK_PORT, SimSettings, worker_address

ROOT = Path(__file__).resolve().parents[2]
PROJECT = Path(__file__).with_name("project")


def _run_project(tmp_path: Path, *args: str, clock: str = "lockstep"):
    """pytest on a copy of the project: (exit code, output, {name: [(worker, host)]})."""
    shutil.copytree(PROJECT, tmp_path / "project")
    record = tmp_path / "record.txt"
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    env.update(FRANKA_SIM_RECORD=str(record), FRANKA_SIM_EXPECTED_CLOCK=clock,
               XDG_DATA_HOME=str(tmp_path / "data"))  # where a Desk keeps its certificate
    # Left exported from a `franka-sim serve` of the user's own: the tests' servers ignore them
    # (else every one would fail to start, or serve another world).
    env.update(FRANKA_SIM_MOBILE_BASE="127.0.0.2", FRANKA_SIM_INJECT="loss=0.5",
               FRANKA_SIM_CLOCK="lockstep" if clock == "realtime" else "realtime")
    # Installed, the package's pytest11 entry point loads the plugin; from a source tree whose
    # installed metadata predates it, load it by name.
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider", "-q", "-ra", *args],
        cwd=tmp_path / "project", env=env, capture_output=True, text=True, timeout=600)
    seen = defaultdict(list)
    for line in record.read_text().splitlines():
        name, worker, host = line.split()
        seen[name].append((worker, host))
    return done.returncode, done.stdout + done.stderr, seen


def _outcomes(output: str) -> dict[str, int]:
    summary = output.strip().splitlines()[-1]
    return {word: int(n) for n, word in re.findall(r"(\d+) (\w+)", summary)}


def _check_run(code: int, output: str, seen) -> None:
    assert code == 1, output
    assert _outcomes(output) == {"passed": 18, "failed": 1, "errors": 2}, output
    # The misspelt marker setting is named, and so are faults the server refused.
    assert "unknown setting 'grip'" in output
    assert "faults={'loss': 2.0} is not valid: loss=2.0: a probability is in [0, 1]" in output
    # The failing test's report carries its own server log lines: its client, not the start.
    section = output.split("franka-sim log (", 1)[1].split("short test summary", 1)[0]
    assert re.search(r"FCI client \S+ connected", section), output
    assert "serving on" not in section
    hosts = {host for entries in seen.values() for _, host in entries}
    assert "127.0.0.1" not in hosts and all(h.startswith("127.") for h in hosts)
    # A marker gets a server of its own, shared by a worker's tests with the same marker values.
    default = {host for _, host in seen["default"]}
    for worker in {worker for worker, _ in seen["no-gripper"]}:
        assert len({host for w, host in seen["no-gripper"] if w == worker}) == 1
    assert not default & {host for _, host in
                          seen["no-gripper"] + seen["limits"] + seen["locked"] + seen["panda"]}
    # Every server is gone with the session.
    for host in hosts:
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection((host, 1337), timeout=2).close()


def test_the_fixture_serially(tmp_path):
    # (without recordings: their start would refuse a client left connected, Hand or arm, and
    # so catch what the reset before each test must catch itself)
    code, output, seen = _run_project(tmp_path, "--franka-sim-record", "none")
    _check_run(code, output, seen)
    assert {worker for entries in seen.values() for worker, _ in entries} == {"-"}
    # The faults the one test left were cleared by the reset before the next, not by a restart.
    assert len(seen["faults"]) == 2 and len({host for _, host in seen["faults"]}) == 1
    # A marker's faults are set per test, on the server of the marker's other settings.
    assert {host for _, host in seen["marked-faults"]} <= {host for _, host in seen["default"]}


def test_the_fixture_on_two_xdist_workers_with_the_realtime_clock(tmp_path):
    code, output, seen = _run_project(tmp_path, "-n", "2", "--franka-sim-clock", "realtime",
                                      clock="realtime")
    _check_run(code, output, seen)
    by_worker = defaultdict(set)
    for entries in seen.values():
        for worker, host in entries:
            by_worker[worker].add(host)
    assert set(by_worker) == {"gw0", "gw1"}
    assert not by_worker["gw0"] & by_worker["gw1"]  # each worker on addresses of its own
    # The failed test's recording is kept; a test whose setup failed (faults the server
    # refused) leaves none.
    kept = sorted(p.name for p in (tmp_path / "project" / "franka-sim-recordings").iterdir())
    assert kept == [recording_name("test_user.py::test_fails_and_shows_the_robot_log")]


def test_the_package_registers_the_plugin():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert declared["pytest11"] == {"franka_sim": "franka_sim.pytest_plugin"}


def test_worker_addresses_are_private_and_apart():
    seen = set()
    for worker in (None, "gw0", "gw1", "gw13"):
        for pid in (4242, 4243):
            for n in range(3):
                address = worker_address(worker, pid, n)
                octets = [int(o) for o in address.split(".")]
                assert octets[0] == 127 and address != "127.0.0.1"
                assert all(0 <= o <= 254 for o in octets)
                seen.add(address)
    assert len(seen) == 3 * 2 * 4 - 2 * 3  # None and gw0 are both worker 0


def test_every_setting_is_passed_as_an_explicit_flag():
    flags = SimSettings(clock="realtime", scene="/x/scene.xml", enforce_motion_limits=True,
                        gripper=False).flags()
    assert flags == ["--clock", "realtime", "--robot", "fr3", "--control-port", "1340",
                     "--enforce-motion-limits",
                     "--no-enforce-comm-constraints", "--scene", "/x/scene.xml", "--no-gripper",
                     "--desk-boot", "ready", "--desk-port", "0"]
    assert SimSettings(robot="fer").flags()[2:4] == ["--robot", "fer"]
    assert SimSettings(desk_boot="locked").flags()[-4:] == [
        "--desk-boot", "locked", "--desk-port", str(DESK_PORT)]


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_a_test_run_killed_outright_leaves_no_server(tmp_path, how):
    """No hook of pytest's runs then: the servers end with the process that started them."""
    project = tmp_path / "killed"
    project.mkdir()
    seen = tmp_path / "host.txt"
    (project / "test_waits.py").write_text(
        "import os, time\n"
        "def test_waits(franka_sim):\n"
        f"    open({str(seen)!r}, 'w').write(franka_sim.host)\n"
        "    time.sleep(600)\n")
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "franka_sim.pytest_plugin"]
    run = subprocess.Popen([sys.executable, "-m", "pytest", *plugin, "-p", "no:cacheprovider",
                            "-q", "--franka-sim-record", "none"], cwd=project,
                           env={k: v for k, v in os.environ.items()
                                if not k.startswith("PYTEST_")},
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not (seen.exists() and seen.read_text()):
            assert run.poll() is None and time.monotonic() < deadline, "the test never ran"
            time.sleep(0.1)
        host = seen.read_text()
        socket.create_connection((host, 1337), timeout=5).close()  # its server serves
        run.send_signal(how)
        run.wait(30)
        deadline = time.monotonic() + 30
        while True:  # (SIGTERM's stop takes the server a moment)
            try:
                socket.create_connection((host, 1337), timeout=2).close()
            except ConnectionRefusedError:
                break
            assert time.monotonic() < deadline, "the server outlived its test run"
            time.sleep(0.1)
    finally:
        run.kill()


def test_a_packaged_scene_name_beside_a_folder_of_that_name_stays_the_packaged_scene(tmp_path):
    from franka_sim.pytest_plugin import _absolute

    (tmp_path / "default").mkdir()  # (a folder is no scene file)
    assert _absolute("default", tmp_path) == "default"
    (tmp_path / "mine.xml").write_text("<mujoco/>")
    assert _absolute("mine.xml", tmp_path) == str(tmp_path / "mine.xml")


def test_a_log_level_above_info_keeps_the_tests_and_their_reports_to_it(tmp_path):
    """FRANKA_SIM_LOG_LEVEL=warning exported: the tests' servers still start (the plugin waits
    for their info start line; before, each test waited a minute and erred with an empty log),
    and a failing test's report and `log` show warnings and above only."""
    (tmp_path / "test_quiet.py").write_text(textwrap.dedent('''
        import pylibfranka

        def test_a_failing_one(franka_sim):
            robot = pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore)
            robot.read_once()
            try:
                franka_sim.control.pose("no_such_body")  # refused: a warning line
            except Exception:
                pass
            assert not franka_sim.log, franka_sim.log
    '''))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    env["FRANKA_SIM_LOG_LEVEL"] = "warning"
    installed = any(ep.name == "franka_sim" for ep in entry_points(group="pytest11"))
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *([] if installed else ["-p", "franka_sim.pytest_plugin"]),
         "-p", "no:cacheprovider", "-q", "-p", "no:randomly", "test_quiet.py"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    output = done.stdout + done.stderr
    assert _outcomes(output) == {"failed": 1}, output
    section = output.split("franka-sim log (", 1)[1].split("short test summary", 1)[0]
    assert " WARNING " in section and " INFO " not in section, section


@pytest.mark.parametrize("setting,valid", [
    ({"clock": "sometimes"}, "(one of 'lockstep', 'realtime')"),
    ({"robot": "ur5"}, "(one of 'fr3', 'fer')"), ({"gripper": "yes"}, "(a bool)")])
def test_a_marker_value_not_valid_says_what_is(setting, valid):
    from franka_sim.pytest_plugin import _marker_values

    with pytest.raises(pytest.fail.Exception) as failed:
        _marker_values(pytest.mark.franka_sim(**setting).mark, Path("."))
    assert str(failed.value).endswith(f"is not valid {valid}")
