"""The client programs a run starts, one process per robot (as a user runs them), and what each
one's outcome must show: the arm's and the base's programs of the suite, with a short motion
each, a Hand move where there is a Hand and a push halfway through the arm's motion when the
run pushes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
ARM_PROGRAM = TESTS / "support" / "arm_program.py"
PUMP_PROGRAM = TESTS / "support" / "pump_program.py"  # in panda-python's environment
BASE_PROGRAM = TESTS / "mobile" / "base_program.py"

ARM_SECONDS = 0.6  # a cosine blend of 0.15 rad: far inside the limits, even when enforced
BASE_TWIST, BASE_SECONDS = (0.1, 0.0, 0.0), 1.0  # its ramps up and down take 0.5 s each
HAND_WIDTH = 0.05  # m, from the open 0.08: nothing in between, so the move succeeds
# In realtime a Python client on a loaded host is now and then held up for 20 ms, and the
# robot rightly aborts on that under --enforce-comm-constraints (tests/clients/
# test_examples_strict.py does the same): the one outcome this machine's timing decides.
HELD_UP = "communication_constraints_violation"


def start_arm(address: str, turn: float, *, hand: bool, push: str) -> subprocess.Popen:
    args = [address, json.dumps([turn, 0, 0, 0, 0, 0, 0]), str(ARM_SECONDS)]
    args += ["--hand", str(HAND_WIDTH)] if hand else []
    args += ["--push", push] if push else []
    return _start(ARM_PROGRAM, *args)


def start_base(address: str) -> subprocess.Popen:
    return _start(BASE_PROGRAM, address, *BASE_TWIST, BASE_SECONDS)


def start_pump(address: str, python: Path) -> subprocess.Popen:
    return _start(PUMP_PROGRAM, address, python=python)


def _start(path: Path, *args, python=sys.executable) -> subprocess.Popen:
    return subprocess.Popen([str(python), str(path), *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def outcome(program: subprocess.Popen) -> tuple[dict | None, str]:
    """The program's JSON line, or None and what it printed when it failed."""
    try:
        out, err = program.communicate(timeout=120)  # a few seconds when all is well
    except subprocess.TimeoutExpired:
        program.kill()
        out, err = program.communicate()
        return None, f"did not finish in 120 s: {(out + err).strip()[-2000:]}"
    if program.returncode != 0:
        return None, f"exit {program.returncode}: {(out + err).strip()[-2000:]}"
    return json.loads(out.strip().splitlines()[-1]), ""


def arm_problems(result: dict, *, hand: bool, push: bool, lockstep: bool,
                 faults: bool) -> list[str]:
    """What is wrong with an arm program's outcome (empty: the motion reached its target, the
    Hand moved, the push landed)."""
    problems = []
    if result["error"]:
        return [f"motion failed: {result['error']} ({result['errors']})"]
    off = max(abs(q - t) for q, t in zip(result["q"], result["target"]))
    if off > 2e-3:  # joint impedance holds the end of the blend within a milli-radian or so
        problems.append(f"stopped {off:.4f} rad off its target")
    if lockstep and not faults and result["min_rate"] != 1.0:
        # lockstep waits for every streaming client: nothing is lost unless injected
        problems.append(f"success rate {result['min_rate']} without injected faults")
    if push and not (result["pushed"] and result["pushed"]["cycles"] > 0):
        problems.append(f"the push did not land: {result['pushed']}")
    if hand:
        moved = result["hand"]
        if not moved["ok"] or abs(moved["width"] - HAND_WIDTH) > 2e-3:
            problems.append(f"the Hand's move to {HAND_WIDTH} m: {moved}")
    return problems


def pump_problems(result: dict) -> list[str]:
    """What is wrong with the pump program's outcome (empty: the pump spoke protocol 1, reported
    a healthy idle device, gave up a vacuum with nothing to seal at its timeout and stopped)."""
    problems = []
    if result["server_version"] != 1:
        problems.append(f"server version {result['server_version']}, not 1")
    states = [result[k] for k in ("initial", "after_vacuum", "final")]
    if any(s["device_status"] != "kGreen" or s["part_present"] for s in states):
        problems.append(f"states {states}")
    if not states[0]["time"] < states[1]["time"] <= states[2]["time"]:
        problems.append(f"the pump's clock stood: {[s['time'] for s in states]}")
    if result["vacuumed"] or not result["stopped"]:
        problems.append(f"vacuum in the air answered {result['vacuumed']}, stop "
                        f"{result['stopped']}")
    return problems


def base_problems(result: dict) -> list[str]:
    """What is wrong with the base program's outcome (empty: it drove as its twist integrates
    and came to rest)."""
    if result["error"]:
        return [f"motion failed: {result['error']}"]
    problems = []
    moved = [a - b for a, b in zip(result["after"], result["before"])]
    expected = [a - b for a, b in zip(result["integrated"], result["before"])]
    if max(abs(m - e) for m, e in zip(moved, expected)) > 2e-3:
        problems.append(f"drove {moved}, its twist integrates to {expected}")
    if "Idle" not in result["mode"]:
        problems.append(f"ended in {result['mode']}")
    return problems


def only_lost_cycles(result: dict | None) -> bool:
    """An arm's motion ran without an error but lost cycles (its success rate below 1)."""
    return bool(result and "min_rate" in result and not result["error"]
                and result["min_rate"] < 1.0)


def held_up(result: dict | None, *, realtime_and_enforced: bool) -> bool:
    """Whether the program's only failure is the abort a held-up host causes (see HELD_UP)."""
    return bool(realtime_and_enforced and result and HELD_UP in result.get("error", ""))
