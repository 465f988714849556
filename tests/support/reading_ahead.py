"""examples/pick_and_place.py's program, by a client that reads one state more before its first
command in each motion, as a slower libfranka client does:

    python tests/support/reading_ahead.py HOST

The example's own functions run; only the robot its move_joints is handed starts each
joint-position motion with an extra control.readOnce().
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import pick_and_place as pp  # noqa: E402


class ReadsAhead:
    """The robot, but a joint-position motion has read one state when it is handed over."""

    def __init__(self, robot) -> None:
        self.robot = robot

    def start_joint_position_control(self, mode):
        control = self.robot.start_joint_position_control(mode)
        control.readOnce()
        return control


shipped_move_joints = pp.move_joints


def move_joints(robot, q_goal, max_speed: float = 0.6) -> None:
    shipped_move_joints(ReadsAhead(robot), q_goal, max_speed)


if __name__ == "__main__":
    pp.move_joints = move_joints  # pick, place and main look it up when they call it
    pp.main(sys.argv[1])
