"""`franka-sim serve`: flags, environment variables, clean stop, another description."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.testing import ServerProcess, fresh_loopback_address

URDF = Path(__file__).resolve().parents[2] / "urdf" / "fr3.urdf"


def test_help_names_every_flag_and_its_environment_variable():
    out = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--help"],
                         capture_output=True, text=True, env={"COLUMNS": "200"}, timeout=60).stdout
    for flag, env in [("--host", "FRANKA_SIM_HOST"), ("--urdf", "FRANKA_SIM_URDF"),
                      ("--clock", "FRANKA_SIM_CLOCK"), ("--log-level", "FRANKA_SIM_LOG_LEVEL"),
                      ("--enforce-comm-constraints", "FRANKA_SIM_ENFORCE_COMM_CONSTRAINTS"),
                      ("--rt-priority", "FRANKA_SIM_RT_PRIORITY")]:
        assert flag in out and env in out


def test_version_is_the_installed_packages():
    from importlib.metadata import version

    done = subprocess.run([sys.executable, "-m", "franka_sim", "--version"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout == f"franka-sim {version('franka-sim')}\n"


def _help_texts():
    """(command, every help text written for it: its docstring and each option's help)."""
    import typer.main

    from franka_sim.cli import app

    group = typer.main.get_command(app)
    for name, command in group.commands.items():
        yield name, [command.help, *(p.help for p in command.params if getattr(p, "help", None))]


@pytest.mark.parametrize("command", ["serve", "check", "replay", "plot", "render"])
def test_every_help_text_is_shown_as_written(command):
    """What `--help` prints is the text as written, brackets included (`franka-sim[plot]` is
    an extra to install, not markup to swallow)."""
    out = subprocess.run([sys.executable, "-m", "franka_sim", command, "--help"],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, "COLUMNS": "1000"}).stdout
    shown = " ".join(re.sub(r"-\n\s+", "-", out).split())  # (click wraps after a hyphen)
    texts = dict(_help_texts())[command]
    assert texts
    for text in texts:  # (a bracket is written escaped, `\\[`, in rich markup)
        assert " ".join(text.replace("\\[", "[").split()) in shown, text
    if command in ("plot", "render"):
        assert f"franka-sim[{command}]" in shown


@pytest.mark.parametrize("command", ["serve", "check", "replay", "plot", "render", "view"])
def test_a_commands_help_fits_80_columns_whole(command):
    """At 80 columns no word of a command's help is cut: each option's environment variable
    and default are shown whole, and no line is wider than the terminal."""
    import typer.main

    from franka_sim.cli import app

    out = subprocess.run([sys.executable, "-m", "franka_sim", command, "--help"],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, "COLUMNS": "80"}).stdout
    assert "…" not in out and max(map(len, out.splitlines())) <= 80
    joined = re.sub(r"-\n\s+", "-", out)
    for param in typer.main.get_command(app).commands[command].params:
        for env in [param.envvar] if isinstance(param.envvar, str) else []:
            assert env in joined, env
        default = getattr(param.default, "value", param.default)  # an enum's, by value
        if isinstance(default, (int, float, str)) and not isinstance(default, bool) \
                and default != "" and getattr(param, "show_default", True) is not False:
            assert f"default: {default}" in " ".join(joined.split()), param.name


def test_the_command_list_is_wrapped_by_the_terminal_alone():
    """`franka-sim --help` lists each command by its docstring's first paragraph, broken into
    lines only where the next word would not fit (not where the docstring's lines end)."""
    import inspect

    import typer.main

    from franka_sim.cli import app

    out = subprocess.run([sys.executable, "-m", "franka_sim", "--help"], capture_output=True,
                         text=True, timeout=60, env={**os.environ, "COLUMNS": "80"}).stdout
    rows: dict[str, list[str]] = {}
    for line in out[out.index("Commands"):].splitlines()[1:]:
        if not line.startswith("│"):
            break
        inner = line[1:-1]  # "│ name    text …   │"
        if inner[1] != " ":
            name = inner.split()[0]
            start = inner.index(inner.split()[1], len(name) + 1)  # where the texts begin
            rows[name] = []
        rows[name].append(inner[start:].strip())
    width = len(inner) - 1 - start  # the texts' column, less its right padding
    for name, command in typer.main.get_command(app).commands.items():
        paragraph = inspect.cleandoc(command.callback.__doc__).split("\n\n")[0]
        lines = rows[name]
        assert " ".join(lines) == " ".join(paragraph.replace("\\[", "[").split()), name
        for line, following in zip(lines, lines[1:]):
            assert len(line) + 1 + len(following.split()[0]) > width, (name, line)


def test_host_from_the_environment_and_sigterm_stops_cleanly():
    host = fresh_loopback_address()
    proc = subprocess.Popen([sys.executable, "-m", "franka_sim", "serve"],
                            env={**__import__("os").environ, "FRANKA_SIM_HOST": host},
                            stderr=subprocess.PIPE, text=True)
    for line in proc.stderr:
        if "serving on" in line:
            assert host in line
            break
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
    del robot
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(10) == 0
    proc.stderr.close()


def test_another_description_is_served_and_simulated(tmp_path):
    heavier = re.sub(r'(<link name="link7">.*?<mass value=")([0-9.]+)',
                     lambda m: m.group(1) + "1.627143", URDF.read_text(), count=1, flags=re.S)
    assert heavier != URDF.read_text()
    path = tmp_path / "heavy_fr3.urdf"
    path.write_text(heavier)
    server = ServerProcess(fresh_loopback_address(), "--urdf", str(path)).wait_ready()
    try:
        robot = pylibfranka.Robot(server.host, pylibfranka.RealtimeConfig.kIgnore)
        state = robot.read_once()
        gravity = np.array(robot.load_model().gravity(state))
        # The client's model is the heavier arm, and the simulated arm holds still with it.
        np.testing.assert_allclose(state.tau_J, gravity, atol=1e-3 * np.abs(gravity).max())
    finally:
        server.stop()


def test_a_description_libfranka_would_reject_is_refused_on_one_line(tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text(URDF.read_text().replace("position_based_velocity_limits", "nothing_here"))
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), "--urdf", str(path)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "position_based_velocity_limits" in done.stderr
    assert "Traceback" not in done.stderr


def test_rt_priority_runs_the_server_under_sched_fifo_or_says_why_not():
    """--rt-priority: every server thread under SCHED_FIFO (the cycle thread inherits it),
    or, where the OS refuses, one warning and a server that still serves."""
    import os

    from franka_sim.testing import running_sim

    with running_sim("--rt-priority", "7", env={"FRANKA_SIM_LOG_LEVEL": "info"}) as sim:
        pid = sim.proc.pid
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        applied = sim.log_matching("running under SCHED_FIFO priority 7")
        refused = sim.log_matching("--rt-priority 7 not applied")
        assert len(applied) + len(refused) == 1
        names = {int(tid): Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
                 for tid in os.listdir(f"/proc/{pid}/task")}
        worker = [tid for tid, name in names.items() if name == "fsim-cycle"]
        assert len(worker) == 1
        for tid in (pid, worker[0]):  # the event loop's thread and the cycle thread
            policy, param = os.sched_getscheduler(tid), os.sched_getparam(tid)
            if applied:
                assert (policy, param.sched_priority) == (os.SCHED_FIFO, 7)
            else:
                assert policy == os.SCHED_OTHER
        del robot


def test_the_server_runs_without_the_cli_machinery():
    """The process started serves (the flags were parsed in a child: tests/server/test_launch.py
    follows each import); MuJoCo's renderer (a server never draws) and OpenSSL (the FCI has no
    TLS) are not resident in it."""
    from franka_sim.testing import running_sim

    with running_sim("--clock", "lockstep") as sim:
        pid = sim.proc.pid
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        assert cmdline[1:5] == [b"-P", b"-m", b"franka_sim", b"serve"]
        maps = Path(f"/proc/{pid}/maps").read_text()
        assert "pydantic_core" not in maps and "mujoco" in maps
        assert "mujoco/_render" not in maps and "glfw" not in maps
        assert "libcrypto" not in maps and "_ssl." not in maps
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot


@pytest.mark.parametrize("args, env, reason", [
    (["--inject", "loss=2"], {}, "loss=2: a probability is in [0, 1]"),
    (["--inject", "burst=20"], {}, "expected N@T"),
    (["--inject", "burst=25@1e400s"], {}, "the start is a whole ms"),
    (["--control-token", " s3cret"], {}, "spaces around it or control characters"),
    (["--inject", "burst=\u00b2@3s"], {}, "expected N@T"),
    ([], {"FRANKA_SIM_INJECT": "delay=fast"}, "--inject (from FRANKA_SIM_INJECT): "),
    (["--inject", "loss=0.1", "--seed", "-1"], {}, "--seed"),
    (["--joint-discontinuity-scale", "nan"], {}, "nan is not a finite scale"),
    ([], {"FRANKA_SIM_JOINT_DISCONTINUITY_SCALE": "inf"}, "inf is not a finite scale"),
    (["--bogus"], {}, "No such option: --bogus"),
])
def test_a_bad_flag_or_variable_is_refused_on_one_line(args, env, reason):
    """One line, whole (`docker logs` and CI keep it so), naming the variable a value came
    from, however wide the terminal."""
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), *args], capture_output=True, text=True,
                          env={**os.environ, "COLUMNS": "40", **env}, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith("python -m franka_sim serve: ")  # (its program's name)
    assert reason in done.stderr and done.stderr.endswith("serve --help')\n")


def test_faults_and_their_seed_from_the_environment():
    from franka_sim.control import Control

    server = ServerProcess(fresh_loopback_address(), env={
        "FRANKA_SIM_INJECT": "loss=0.01,delay=2ms,jitter=0.5ms", "FRANKA_SIM_SEED": "7"})
    try:
        server.wait_ready()
        report = Control(server.host).faults()
        assert report["spec"] == "loss=0.01,delay=2ms,jitter=0.5ms" and report["seed"] == 7
        # the start's log says so (a reader of `docker logs` alone sees the faults are on)
        assert server.log_matching(
            "serving with: network faults loss=0.01,delay=2ms,jitter=0.5ms (seed 7)")
    finally:
        server.stop()


def test_faults_that_inject_nothing_are_not_said_to_be_on():
    """--inject loss=0 (a sweep's baseline): nothing is set, and the start's log says none."""
    from franka_sim.control import Control

    server = ServerProcess(fresh_loopback_address(), env={"FRANKA_SIM_INJECT": "loss=0"})
    try:
        server.wait_ready()
        assert Control(server.host).faults()["spec"] is None
        assert server.log_matching("serving on") and not server.log_matching("network faults")
    finally:
        server.stop()


def test_render_help_names_every_video_it_writes():
    from franka_sim.playback.render import VIDEO_SUFFIXES

    out = subprocess.run([sys.executable, "-m", "franka_sim", "render", "--help"],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, "COLUMNS": "200"}).stdout
    assert all(suffix in out for suffix in VIDEO_SUFFIXES), out
