"""What one simulated robot is: the CLI parses flags/env into this, FrankaSim consumes it."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

import numpy as np

# The pose libfranka's examples move to before they start ("ready"): a comfortable,
# non-singular configuration well inside every joint range.
READY_POSE = (0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4)


class ClockMode(str, Enum):
    realtime = "realtime"
    lockstep = "lockstep"


@dataclass
class Config:
    host: str = "127.0.0.1"
    robot_port: int = 1337  # libfranka pins it; other values only serve raw-socket clients
    urdf: Path | None = None  # None: the packaged FR3 description
    clock: ClockMode = ClockMode.realtime
    enforce_comm_constraints: bool = False  # abort after 20 lost cycles, as the robot does
    q0: tuple[float, ...] = field(default=READY_POSE)
