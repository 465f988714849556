"""In a world of several robots, a log line says which robot it is about (log_names.py)."""

from __future__ import annotations

import logging

from franka_sim.config import ArmSpec, Config
from franka_sim.log_names import RobotName, about, name_work

log = logging.getLogger("franka_sim.robot.arm_core")


class _Part:
    def drive(self, say: str) -> str:
        log.warning(say)
        return say


def _lines(caplog) -> list[str]:
    return [f"{r.robot}{r.getMessage()}" for r in caplog.records]


def test_the_work_of_a_named_robot_logs_under_its_name(caplog):
    left, right = _Part(), _Part()
    name_work(left, "left", ("drive",))
    name_work(right, "right", ("drive",))
    caplog.handler.addFilter(RobotName())  # (as the server's handler has it)
    with caplog.at_level("WARNING"), about(None):
        assert left.drive("driven") == "driven"
        right.drive("driven")
        log.warning("the world's")
        with about("base"):
            log.warning("moved")
    assert _lines(caplog) == ["left: driven", "right: driven", "the world's", "base: moved"]


def test_the_cycle_names_each_robot_of_several_and_a_lone_one_not():
    from franka_sim.assembly import PART_WORK, WorldParts

    for config, named in ((Config(), False), (Config(scene="dual_arm_table", arms=(
            ArmSpec("left", "127.0.0.2"), ArmSpec("right", "127.0.0.3"))), True)):
        parts = WorldParts(config)
        cycle = parts.make_cycle(parts.make_physics(), [lambda: False] * len(parts.robots))
        for part in cycle.parts:
            assert all((work in vars(part)) is named for work in PART_WORK)
            assert ("release_cycle" in vars(part.core)) is named
