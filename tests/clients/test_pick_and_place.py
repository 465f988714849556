"""examples/pick_and_place.py moves the default scene's cube, end to end, and the cube is where it
was put.

Nothing new is exposed on the wire to check it: afterwards the test itself goes back with the
arm and the Hand. A grasp where the cube used to be closes on nothing (pylibfranka returns False,
the fingers close), and a grasp at the place position holds an object of the cube's width. The
tolerance on the cube's position is what a grasp tolerates: the open fingers (8 cm) close on a
5 cm cube only if it lies within ±1.5 cm across them, and the pads (3.5 cm tall) reach it only
if it rests on the table there.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pylibfranka
import pytest

from franka_sim.testing import running_sim

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
sys.path.insert(0, str(EXAMPLES))
import pick_and_place as pp  # noqa: E402


@pytest.fixture(scope="module")
def after_pick_and_place():
    with running_sim("--clock", "lockstep") as sim:
        done = subprocess.run([sys.executable, str(EXAMPLES / "pick_and_place.py"), sim.host],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        yield sim, done.stdout


def test_the_example_grasps_and_places(after_pick_and_place):
    _, out = after_pick_and_place
    assert "is_grasped True" in out and "placed the cube at [0.45, 0.2, 0.025]" in out


def test_the_cube_is_where_it_was_placed(after_pick_and_place):
    sim, _ = after_pick_and_place
    robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
    gripper = pylibfranka.Gripper(sim.host)
    robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
    assert pp.pick(robot, gripper, pp.CUBE) is False  # gone from where it was
    assert gripper.read_once().width < 1e-3
    assert pp.pick(robot, gripper, pp.PLACE) is True  # and there
    state = gripper.read_once()
    assert state.is_grasped and state.width == pytest.approx(pp.CUBE_SIZE, abs=1e-3)
