"""A grasp reproduces in lockstep however many states the client reads before it answers.

libfranka reads one or two states after a motion's first before it sends a command, depending
on how fast the client runs. The lockstep clock holds the world until a motion's first command
(server/clock.py), so examples/pick_and_place.py as shipped and the same program by a client
that reads one state more in each motion (support/reading_ahead.py) leave the cube and the
arm in the same bits, each on a fresh lockstep server. Only the robot's time may differ: the
held states go out under message_ids of their own.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka

from franka_sim.control import Control
from franka_sim.testing import running_sim

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "examples" / "pick_and_place.py"
READING_AHEAD = ROOT / "tests" / "support" / "reading_ahead.py"


def _bits(value):
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):  # errors, the robot mode: by what they say
        return str(value)


def _final_world(program: Path) -> dict:
    """Run `program` on a fresh lockstep server; then the cube's pose, every field of the
    robot's state but its time, and the Hand's state."""
    with running_sim("--clock", "lockstep") as sim:
        done = subprocess.run([sys.executable, str(program), sim.host],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        assert "is_grasped True" in done.stdout
        state = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore).read_once()
        hand = pylibfranka.Gripper(sim.host).read_once()
        world = {name: _bits(getattr(state, name)) for name in dir(state)
                 if not name.startswith("_") and name != "time"}
        world["hand"] = _bits([hand.width, hand.max_width, hand.is_grasped, hand.temperature])
        cube = Control(sim.host).pose("cube")
        world["cube"] = _bits([*cube["position"], *cube["quaternion"], *cube["linear_velocity"],
                               *cube["angular_velocity"]])
    return world


def test_reading_one_more_state_per_motion_changes_no_bit_of_the_grasp():
    shipped, reading_ahead = _final_world(SHIPPED), _final_world(READING_AHEAD)
    differ = {name: (shipped[name], reading_ahead[name]) for name in shipped
              if not np.array_equal(shipped[name], reading_ahead[name])}
    assert differ == {}
