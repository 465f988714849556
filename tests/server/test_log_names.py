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


def test_a_recording_keeps_which_robot_each_line_is_about(tmp_path):
    """Its /log lines carry the robot's name as the console's do (`right: FCI client …`)."""
    from franka_sim.recording.reader import open_recording
    from support.replayed import right_arm_only

    path = tmp_path / "r.mcap"
    with right_arm_only(path) as (server, right):
        assert server.wait_for_log("right: FCI client")
        assert server.log_matching(f"right: simulated FR3 serving on {right}:1337")
    lines = [e.json() for e in open_recording(path).of("log")]
    connected = [line for line in lines if "FCI client" in line["message"]]
    assert connected and all(line.get("robot") == "right" for line in connected), connected
    assert any("robot" not in line for line in lines)  # the world's own lines name none


def test_a_thread_started_by_one_of_several_simulators_names_it(caplog):
    from franka_sim.log_names import ContextThread, SimName

    first, second = SimName("127.0.0.2"), SimName("127.0.0.3")
    caplog.handler.addFilter(RobotName())
    with caplog.at_level("WARNING"):
        first.serving(True)
        with first.current():
            log.warning("alone")  # (the only one serving: unnamed)
        try:
            second.serving(True)
            with second.current():
                thread = ContextThread(target=log.warning, args=("in its thread",))
                with about("left"):
                    thread.start()
            thread.join()
            log.warning("the process's own")
        finally:
            first.serving(False)
            second.serving(False)
    assert _lines(caplog) == ["alone", "127.0.0.3: left: in its thread", "the process's own"]
