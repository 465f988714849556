"""What `franka-sim replay` says of a recording it finds identical, counted from the file: each
cycle whose states were recorded (once, however many robots), and every tool state; and the
committed recordings replayed on the numerical kernels they were made with."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest

from franka_sim.playback.replay import Outcome
from franka_sim.recording.channels import TOOL_STATE_KEYS
from franka_sim.recording.reader import Recording


def identical_line(recording: Recording, until: int | None = None) -> str:
    cycles = {int.from_bytes(e.data[:8], "little") for e in recording.entries
              if e.key == "robot_state"}
    tools = [int.from_bytes(e.data[:4], "little") for e in recording.entries
             if e.key in TOOL_STATE_KEYS.values()]
    if until is not None:
        cycles, tools = {n for n in cycles if n <= until}, [n for n in tools if n <= until]
    return Outcome(cycles=len(cycles), tool_states=len(tools)).line()  # (replay's own words)


# The committed recordings (tests/data) were made on x86_64 with OpenBLAS's Haswell core, before
# recordings kept their kernels. Where OpenBLAS picks another core (SkylakeX on an AVX-512 CPU)
# a product's last bits differ, and so does a replay (docs/recording.md, "Across machines"):
# they are replayed on the core they were made with, as that page tells a user to.
COMMITTED_OPENBLAS_CORE = "Haswell"


def replay_committed(path: Path, *args: str, env: dict | None = None
                     ) -> subprocess.CompletedProcess:
    """`franka-sim replay` of a committed recording, on the kernels it was recorded with."""
    if platform.machine() != "x86_64":
        pytest.skip("the committed recordings replay bit for bit on x86_64 only")
    env = {**(os.environ if env is None else env), "OPENBLAS_CORETYPE": COMMITTED_OPENBLAS_CORE}
    return subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path), *args],
                          capture_output=True, text=True, timeout=300, env=env)


@contextmanager
def right_arm_only(path: Path):
    """A recording to `path` of two arms (dual_arm_table) whose right arm alone had a client,
    which read one state: yields the server (stopped on leaving) and the right arm's address."""
    from franka_sim.testing import ServerProcess, fresh_loopback_address
    from support.clients import connect

    left, right = fresh_loopback_address(), fresh_loopback_address()
    server = ServerProcess(left, "--scene", "dual_arm_table", "--arm", f"left={left}",
                           "--arm", f"right={right}", "--record", str(path))
    try:
        server.wait_ready()
        connect(right).read_once()
        yield server, right
    finally:
        server.stop()
