"""What `franka-sim replay` says of a recording it finds identical, counted from the file: each
cycle whose states were recorded (once, however many robots), and every tool state."""

from __future__ import annotations

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
