"""Every one-arm program in examples/, recorded in both clocks, replays bit for bit.

Which programs: each examples/*.py carries its usage line in its docstring,
`python NAME.py HOST [ARG]...`. A program whose usage takes one address (then only optional,
bracketed arguments) drives one arm and is run here; one that takes two addresses drives two
arms in one world (test_bimanual.py runs those). A new example joins by its usage line; one
without one fails `test_every_program_says_how_to_run_it_on_one_arm_or_two`.

How: each is served as its docstring says (a `franka-sim serve ...` line there gives its flags;
the clock is the test's), recording, and run unmodified as a subprocess with ARGS, the
shortest arguments that still exercise it (none: its own defaults). The server stops on
SIGTERM, then replay (what `franka-sim replay` runs) must find every recorded cycle identical.

In realtime a program served with --enforce-comm-constraints may be aborted by a host that
held its client up for 20 cycles: the run is no less a recording, and its replay is checked
all the same.
"""

from __future__ import annotations

import ast
import re
from collections import Counter
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from franka_sim.playback.replay import replay
from franka_sim.recording.reader import open_recording
from franka_sim.testing import running_sim
from support.replayed import identical_line

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
HELD_UP = "communication_constraints_violation"

# The arguments tests/clients and tests/robot run them with; force_control and
# generate_consecutive_motions, which those run for long, here press for 1 s (the force rising)
# and swing once (right after the motion to the ready pose: two motions back to back).
ARGS = {
    "echo_robot_state": ["3"],
    "communication_test": ["2000"],
    "joint_impedance_control": ["3"],
    "cartesian_impedance_control": ["2"],
    "generate_cartesian_pose_motion": ["4"],
    "generate_elbow_motion": ["0.3"],
    "force_control": ["1"],
    "generate_consecutive_motions": ["1"],
}


def _docstring(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text())) or ""


def _usage(path: Path) -> list[str] | None:
    """The arguments of the program's usage line (`python NAME.py ...`), None without one."""
    found = re.search(rf"python {re.escape(path.name)} ([^\n]*)", _docstring(path))
    return found.group(1).split() if found else None


def _programs() -> list[Path]:
    """The examples a user runs: the modules with a `__main__` block."""
    return sorted(p for p in EXAMPLES.glob("*.py") if '__name__ == "__main__"' in p.read_text())


def _addresses(path: Path) -> int:
    """How many addresses the usage line asks for: its arguments not in brackets."""
    return sum(not a.startswith("[") for a in _usage(path) or [])


def _serve_flags(path: Path) -> list[str]:
    """The flags of the docstring's `franka-sim serve` line, but the clock and the address."""
    found = re.search(r"franka-sim serve([^\n]*)", _docstring(path))
    words, flags = shlex.split(found.group(1)) if found else [], []
    while words:
        word = words.pop(0)
        if word in ("--clock", "--host"):
            words.pop(0)
        else:
            flags.append(word)
    return flags


ONE_ARM = [p for p in _programs() if _addresses(p) == 1]


def test_every_program_says_how_to_run_it_on_one_arm_or_two():
    assert {p.name: _usage(p) for p in _programs() if _addresses(p) not in (1, 2)} == {}


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
@pytest.mark.parametrize("program", ONE_ARM, ids=lambda p: p.stem)
def test_the_recorded_program_replays_identical(program, clock, tmp_path):
    path, flags = tmp_path / "run.mcap", _serve_flags(program)
    with running_sim("--clock", clock, "--record", str(path), *flags) as sim:
        done = subprocess.run([sys.executable, str(program), sim.host, *ARGS.get(program.stem, [])],
                              capture_output=True, text=True, timeout=300)
    assert sim.proc.returncode == 0, "\n".join(sim.lines)  # SIGTERM closed the recording
    out = done.stdout + done.stderr
    held_up = (clock == "realtime" and "--enforce-comm-constraints" in flags
               and set(re.findall(r'\["(\w+)"\]', out)) == {HELD_UP})
    assert done.returncode == 0 or held_up, out

    recording = open_recording(path)  # replayed in this process: `franka-sim replay` runs the
    cycles = len(recording.states())  # same (its CLI path: test_record_replay.py)
    assert cycles > 0
    assert replay(recording).line() == identical_line(recording)
    # On the wire: every reply once (one connection: each command id answered once per status).
    sent = Counter((reply["service"], r.get("command"), r.get("command_id"), r.get("status"))
                   for reply in (e.json() for e in recording.of("reply", None))
                   for r in reply["replies"])
    assert [key for key, n in sent.items() if n > 1] == []
