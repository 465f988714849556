"""The GitHub composite action (action.yml), offline: its interface, and its two scripts run as
the runner runs them (RUNNER_TEMP, GITHUB_OUTPUT) against a real server, with the franka-sim
already installed here (install: false)."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from franka_sim.testing import fresh_loopback_address

yaml = pytest.importorskip("yaml")

ROOT = Path(__file__).resolve().parents[2]
ACTION = yaml.safe_load((ROOT / "action.yml").read_text())
SCRIPTS = ROOT / "deploy" / "action"


def test_the_action_takes_its_inputs_and_gives_the_address():
    assert ACTION["runs"]["using"] == "composite"
    inputs = ACTION["inputs"]
    assert {"package", "install", "host", "args", "wait", "stop"} <= inputs.keys()
    assert all(spec.get("description") for spec in inputs.values())
    assert inputs["host"]["default"] == "127.0.0.1" and inputs["stop"]["default"] == "false"
    outputs = ACTION["outputs"]
    assert {"host", "control-url", "log"} <= outputs.keys()
    for name, spec in outputs.items():
        assert spec["value"] == f"${{{{ steps.start.outputs.{name} }}}}"


def test_every_input_reaches_the_step_that_uses_it():
    steps = {step.get("id"): step for step in ACTION["runs"]["steps"]}
    passed = " ".join(steps["start"]["env"].values())
    for name in ACTION["inputs"].keys() - {"stop", "artifact-name"}:
        assert f"inputs.{name} }}" in passed, name
    assert steps["start"]["if"] == "inputs.stop != 'true'"
    assert steps["stop"]["if"] == "inputs.stop == 'true'"
    (upload,) = [s for s in ACTION["runs"]["steps"] if "upload-artifact" in s.get("uses", "")]
    assert "steps.stop.outputs.log-dir" in upload["with"]["path"]


def test_the_steps_run_scripts_that_exist_and_parse():
    for step in ACTION["runs"]["steps"]:
        if "run" in step:
            assert step["shell"] == "bash"
            (path,) = re.findall(r"\$GITHUB_ACTION_PATH/(\S+\.sh)", step["run"])
            script = ROOT / path
            assert os.access(script, os.X_OK), path
            subprocess.run(["bash", "-n", str(script)], check=True)


def _runner_env(tmp_path: Path, **inputs: str) -> dict:
    sim = shutil.which("franka-sim") or str(Path(sys.executable).parent / "franka-sim")
    env = {**os.environ, "RUNNER_TEMP": str(tmp_path), "GITHUB_OUTPUT": str(tmp_path / "out"),
           "PATH": f"{Path(sim).parent}{os.pathsep}{os.environ['PATH']}",
           "FRANKA_SIM_ACTION_INSTALL": "false",
           # A narrow terminal, as a runner may report: ps must not cut the command lines the
           # scripts read (a venv's path is long).
           "COLUMNS": "40"}
    env.update({f"FRANKA_SIM_ACTION_{k.upper()}": v for k, v in inputs.items()})
    return env


def _outputs(tmp_path: Path) -> dict:
    lines = (tmp_path / "out").read_text().splitlines()
    return dict(line.split("=", 1) for line in lines)


def _script(name: str, env: dict, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([str(SCRIPTS / name)], env=env, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


def test_start_serves_until_stop_which_keeps_the_log(tmp_path):
    import pylibfranka

    host = fresh_loopback_address()
    env = _runner_env(tmp_path, host=host, args="--clock lockstep", wait="60")
    started = _script("start.sh", env)
    assert started.returncode == 0, started.stdout + started.stderr
    out = _outputs(tmp_path)
    assert out["host"] == host and out["control-url"] == f"http://{host}:1340"
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        robot = pylibfranka.Robot(out["host"], pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot
    finally:  # libfranka raised this thread to SCHED_FIFO 99, which later tests would inherit
        os.sched_setscheduler(0, policy, param)
    (pid, _), = [line.split() for line in (tmp_path / "franka-sim" / "servers").read_text()
                 .splitlines()]

    stopped = _script("stop.sh", env)
    assert stopped.returncode == 0, stopped.stdout + stopped.stderr
    assert not Path(f"/proc/{pid}").exists() or "Z" in _state(pid)
    assert _outputs(tmp_path)["log-dir"] == str(tmp_path / "franka-sim" / "logs")
    log = Path(out["log"]).read_text()
    assert "serving on" in log and "stopping" in log
    assert _script("stop.sh", env).stdout.strip() == "no franka-sim was started in this job"


def test_the_args_may_name_a_token_and_other_addresses(tmp_path):
    """Ready is asked where the args say it serves (the serving file), with their token; the
    output names the first arm."""
    left, right = fresh_loopback_address(), fresh_loopback_address()
    env = _runner_env(tmp_path, host=fresh_loopback_address(), wait="60",
                      args=f"--control-token abc --arm left={left} --arm right={right} "
                           "--scene dual_arm_table --clock lockstep")
    started = _script("start.sh", env)
    try:
        assert started.returncode == 0, started.stdout + started.stderr
        out = _outputs(tmp_path)
        assert out["host"] == left and out["control-url"] == f"http://{left}:1340"
    finally:
        assert _script("stop.sh", env).returncode == 0


def _state(pid: str) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()[0]
    except OSError:
        return "gone"


def test_a_server_that_cannot_start_fails_the_step_at_once_with_its_log(tmp_path):
    host = fresh_loopback_address()
    env = _runner_env(tmp_path, host=host, wait="60")
    with socket.socket() as taken:
        taken.bind((host, 1337))
        taken.listen()
        start = time.monotonic()
        started = _script("start.sh", env)
        took = time.monotonic() - start
    assert started.returncode == 1
    assert took < 30  # not the whole wait: the server's exit ends it
    assert "::error title=franka-sim::franka-sim did not become ready" in started.stdout
    assert f"{host}:1337 is already in use" in started.stdout  # the log's tail


def test_by_default_it_installs_the_franka_sim_it_belongs_to(tmp_path):
    """Not `pip install franka-sim`: that name on PyPI is another project's (a simulator with
    no `franka-sim` command, binding 0.0.0.0). The runner's python3 is replaced by one whose
    venv's pip writes down what it was asked for, then gives the franka-sim installed here."""
    shims, asked = tmp_path / "shims", tmp_path / "asked"
    shims.mkdir()
    sim = shutil.which("franka-sim") or str(Path(sys.executable).parent / "franka-sim")
    (shims / "python3").write_text(f"""#!/bin/sh
[ "$1 $2" = "-m venv" ] || exit 2
mkdir -p "$3/bin"
printf '#!/bin/sh\\necho "$@" >>{asked}\\nln -s {sim} %s/bin/franka-sim\\n' "$3" >"$3/bin/pip"
chmod +x "$3/bin/pip"
""")
    (shims / "python3").chmod(0o755)
    host = fresh_loopback_address()
    env = _runner_env(tmp_path, host=host, install="true", wait="60")
    env["PATH"] = f"{shims}{os.pathsep}{env['PATH']}"
    started = _script("start.sh", env)
    try:
        assert started.returncode == 0, started.stdout + started.stderr
        assert asked.read_text().split()[-1] == str(ROOT)
    finally:
        _script("stop.sh", env)
