"""In lockstep the robot's time is simulated time: the same pylibfranka program, with pauses of
50 ms and 500 ms between its motions and a Hand move, reads states with the same message_ids
(libfranka's `time`) on two fresh servers, and so does a client slow over each motion's first
command. Idle gaps past the 100 ms window count as whole simulated seconds (server/clock.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from franka_sim.testing import running_sim

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "paused_program.py"


def _times(*flags: str) -> list[int]:
    with running_sim("--clock", "lockstep") as sim:
        done = subprocess.run([sys.executable, str(PROGRAM), sim.host, *flags],
                              capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_a_program_with_pauses_reads_the_same_message_ids_on_two_fresh_servers():
    first, second, slow = _times(), _times(), _times("--slow-start")
    assert len(first) > 800  # every state of four motions, and the reads between
    assert first == second
    assert slow == first  # 20 ms over a first command: no state more, none later
    steps = sorted({b - a for a, b in zip(first, first[1:])})
    assert steps[0] == 1 and steps[-1] > 1000  # 1 ms apart in motion; a paused second between
