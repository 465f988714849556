"""What a recording's client did, on the robot's clock: motions (Move to its end), errors,
lost cycles, Hand actions. Shared by the plot and anyone reading a run."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from franka_sim.protocol.enums import RobotMode
from franka_sim.protocol.errors import ERROR_NAMES
from franka_sim.recording.reader import Recording


@dataclass(frozen=True)
class Mark:
    cycle: int
    label: str


def motion_starts(recording: Recording, robot: str | None = None) -> list[Mark]:
    """Each Move request of a robot (None: the first), at the cycle it was handled."""
    marks = []
    for entry in recording.of("tcp", robot):
        event = entry.json()
        for request in event["requests"]:
            if event["service"] == "robot" and request.get("command") == "Move":
                marks.append(Mark(event["cycle"], str(request.get("motion_generator_mode",
                                                                  "Move"))))
    return marks


def motion_ends(recording: Recording, robot: str | None = None) -> list[Mark]:
    """Each Move's final reply (success, a reflex, aborted) at the cycle it left."""
    marks = []
    for entry in recording.of("reply", robot):
        event = entry.json()
        for reply in event["replies"]:
            if (event["service"] == "robot" and reply.get("command") == "Move"
                    and reply.get("status") != "kMotionStarted"):
                marks.append(Mark(event["cycle"], str(reply.get("status"))))
    return marks


def lost_cycles(recording: Recording, robot: str | None = None) -> list[Mark]:
    """Each motion cycle that closed without an on-time command, labelled with how the robot
    filled it (`extrapolated`, `held`, `braked`, ...: robot/events.py)."""
    return [Mark(event["cycle"], event["filled"])
            for event in (entry.json() for entry in recording.of("lost_cycle", robot))]


def error_onsets(states: np.ndarray) -> list[Mark]:
    """The cycles at which an error bit came on, with its name."""
    errors = states["errors"].astype(bool)
    if len(errors) == 0:
        return []
    before = np.vstack([np.zeros((1, errors.shape[1]), bool), errors[:-1]])
    marks = []
    for row, col in zip(*np.nonzero(errors & ~before)):
        marks.append(Mark(int(states["message_id"][row]), ERROR_NAMES[col]))
    return marks


def mode_names() -> dict[int, str]:
    return {int(m): m.name[1:] for m in RobotMode}
