"""Features of `franka-sim serve` in combination: each run of the pairwise set (matrix.py) serves
its world with its flags, drives every robot of it at once with a pylibfranka program of its
own (and, with the vacuum gripper, each arm's pump with panda-python's VacuumGripper), and
then checks that the clocks still run, `/health` is ready, a recording replays
identical and the server exits 0 on SIGTERM.

Every problem a run shows is collected, so that one failure report names all of them.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pylibfranka
import pytest

from combinations import programs
from combinations.factors import WORLDS, Site, factors
from combinations.matrix import run_id, runs
from franka_sim.control import Control
from franka_sim.testing import ServerProcess, fresh_loopback_address

FACTORS = factors()
RUNS = runs(FACTORS)


@pytest.mark.parametrize("run", RUNS, ids=[run_id(run) for run in RUNS])
def test_a_run_of_the_matrix(run, tmp_path, request):
    world = WORLDS[run["world"]]
    names = [name for name, _ in world.arms] + (["base"] if world.base else [])
    where = Site(tmp_path, {name: fresh_loopback_address() for name in names})
    args = [arg for factor in FACTORS for arg in factor.args(run[factor.name], where)]
    env = {"DISPLAY": request.getfixturevalue("x_display")} if run["viewer"] else None
    server = ServerProcess(where.addresses[names[0]], *args, env=env).wait_ready()
    problems: list[str] = []
    try:
        held = _drive(run, world, where, problems, request)
        _check_still_running(where, held, problems)
    finally:
        died = server.proc.poll()
        took = server.stop()
    if died is not None:
        problems.append(f"the server died during the run (exit {died})")
    elif server.proc.returncode != 0 or took == float("inf"):
        problems.append(f"SIGTERM: exit {server.proc.returncode} after {took:.1f} s")
    if run["record"]:
        problems += _replay_problems(where.folder / "run.mcap")
    if problems:  # what the server said last is most often why
        problems.append("the server's last lines:\n" + "\n".join(server.lines[-30:]))
    assert not problems, f"{' '.join(args)}\n" + "\n".join(problems)
    if held:
        pytest.skip(f"the host held {', '.join(held)} up: 20 cycles in realtime, or past "
                    "lockstep's window")


def _drive(run: dict, world, where: Site, problems: list[str], request) -> list[str]:
    """Start every robot's program at once and judge each outcome; returns the robots whose
    client the host held up (programs.HELD_UP)."""
    hand = run["tool"] == "hand"
    started = {}
    for name, turn in world.arms:
        body = "hand" if world.scene is None else f"{name}/hand"  # a lone arm's names are bare
        started[name] = programs.start_arm(where.addresses[name], turn, hand=hand,
                                           push=body if run["push"] else "")
    if world.base:
        started["base"] = programs.start_base(where.addresses["base"])
    if run["tool"] == "vacuum":  # each arm's pump, driven beside its arm's motion
        python = request.getfixturevalue("panda_python")
        for name, _ in world.arms:
            started[f"{name}'s pump"] = programs.start_pump(where.addresses[name], python)
    outcomes = {name: programs.outcome(program) for name, program in started.items()}
    held = []
    # Lockstep waits for each answer up to a window of wall time (server/pacing.py); a client
    # the host held up past it loses that cycle, and the world says so (GET /faults). (With
    # injected faults a dropped answer runs its window out too, and lost cycles are expected.)
    ran_out = (run["clock"] == "lockstep" and not run["inject"]
               and _windows_run_out(where) > 0)
    for name, (result, failure) in outcomes.items():
        if programs.held_up(result, realtime_and_enforced=run["clock"] == "realtime"
                            and run["enforce_comm_constraints"]):
            held.append(name)
            continue
        if ran_out and programs.only_lost_cycles(result):
            held.append(name)  # and the rest of its outcome judged below
        if result is None:
            problems.append(f"{name}'s program: {failure}")
        elif name == "base":
            problems += [f"base: {p}" for p in programs.base_problems(result)]
        elif name.endswith("pump"):
            problems += [f"{name}: {p}" for p in programs.pump_problems(result)]
        else:  # (cycles lost past lockstep's window are the host's, as injected ones are)
            problems += [f"{name}: {p}" for p in programs.arm_problems(
                result, hand=hand, push=run["push"], lockstep=run["clock"] == "lockstep",
                faults=run["inject"] or ran_out)]
    return held


def _windows_run_out(where: Site) -> int:
    """Lockstep cycles the world released without the answer they waited for."""
    return Control(next(iter(where.addresses.values()))).faults()["windows_run_out"]


def _check_still_running(where: Site, held: list[str], problems: list[str]) -> None:
    """Every robot answers /health ready and Idle (a held-up one is in Reflex), and a client
    that connects now reads states whose time goes on past the cycle /health reported."""
    for name, address in where.addresses.items():
        try:
            health = Control(address).health()
            robot = pylibfranka.Robot(address, pylibfranka.RealtimeConfig.kIgnore)
            times = [round(robot.read_once().time.to_sec() * 1000) for _ in range(2)]
            del robot
        except Exception as exc:  # noqa: BLE001 - a problem of this run, reported with the rest
            problems.append(f"{name}: after the motions: {type(exc).__name__}: {exc}")
            continue
        if not health["ready"] or (health["robot_mode"] != "Idle" and name not in held):
            problems.append(f"{name}: /health after the motions: {health}")
        if not health["cycle"] <= times[0] < times[1]:
            problems.append(f"{name}: the clock stood: /health at cycle {health['cycle']}, "
                            f"then states at {times}")


def _replay_problems(path) -> list[str]:
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=600)
    line = done.stdout.strip()
    found = re.fullmatch(r"identical \((\d+) cycles?(, \d+ tool states?)?\)", line)
    if done.returncode != 0 or not found or int(found.group(1)) == 0 or done.stderr:
        return [f"replay: exit {done.returncode}: {(line + done.stderr).strip()[-2000:]}"]
    return []
