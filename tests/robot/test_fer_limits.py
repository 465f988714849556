"""The Panda (FER): its packaged description and limits are the published ones
(tests/data/fer_limits.md), and the checks hold a Panda's stream to them and an FR3's to the
FR3's: the same stream can break one robot's limit and not the other's."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.description.kinematics import flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.robot.checks import figures as L
from franka_sim.robot.checks.commands import command_checker_for
from franka_sim.robot.checks.joint_table import joint_limits
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from test_limits import _numbers, _table  # noqa: E402 - the markdown readers of the FR3's

FER = load_arm_description(default_urdf_text("fer"))
FR3 = load_arm_description(default_urdf_text("fr3"))
FACTS = Path(__file__).resolve().parents[1] / "data" / "fer_limits.md"


def test_the_description_and_the_figures_are_the_datasheets():
    text = FACTS.read_text(encoding="utf-8")
    rows = _table(text, "| Joint | q min/max")
    table = joint_limits(FER)
    assert FER.name == "fer" and L.motion_figures(FER) is L.FER
    for i, row in enumerate(rows):
        assert _numbers(row[1]) == [table.lower[i], table.upper[i]]
        velocity, acceleration, jerk, effort, rate = (float(x) for x in row[2:7])
        assert (table.velocity[i], table.effort[i], rate) == (velocity, effort, L.TORQUE_RATE)
        assert (L.FER.joint_acceleration[i], L.FER.joint_jerk[i]) == (acceleration, jerk)
    cartesian = {row[0]: tuple(_numbers(" ".join(row[1:])))
                 for row in _table(text, "| Quantity | Velocity")}
    for key, envelope in (("Translation", L.FER.translation), ("Rotation", L.FER.rotation),
                          ("Elbow", L.FER.elbow)):
        assert (envelope.velocity, envelope.acceleration, envelope.jerk) == cartesian[key]


def test_its_kinematics_are_the_fr3s_and_its_dynamics_its_own():
    rng = np.random.default_rng(1)
    for q in rng.uniform(-1.0, 1.0, size=(5, 7)):
        assert np.array_equal(flange_pose(FER, q), flange_pose(FR3, q))
    assert FER.inertials["link2"].mass != FR3.inertials["link2"].mass


def _joint_ramp(desc, joint: int, acceleration: float, n: int = 60) -> list[str]:
    """A q_c stream accelerating one joint from rest at `acceleration`; the errors it raises."""
    checker = command_checker_for(desc, Gen.kJointPosition, False, q_start=READY_POSE)
    q0, out = np.array(READY_POSE), []
    for k in range(n):
        q = q0.copy()
        q[joint] += 0.5 * acceleration * (k * 1e-3) ** 2
        checker.judge({"q_c": q}, 1, out)
    return sorted({v.name for v in out})


def test_a_joint_stream_is_held_to_its_robots_acceleration():
    """12 rad/s² on joint 1: inside the Panda's 15, over the FR3's 10; 9 rad/s² on joint 2:
    over the Panda's 7.5, inside the FR3's."""
    assert _joint_ramp(FER, 0, 12.0) == []
    assert "joint_motion_generator_velocity_discontinuity" in _joint_ramp(FR3, 0, 12.0)
    assert "joint_motion_generator_velocity_discontinuity" in _joint_ramp(FER, 1, 9.0)
    assert _joint_ramp(FR3, 1, 9.0) == []


def test_a_cartesian_velocity_is_held_to_its_robots_envelope():
    """2 m/s, reached at 8 m/s² with a gentle jerk: over the Panda's 1.7, inside the FR3's 3."""
    def errors(desc) -> list[str]:
        checker = command_checker_for(desc, Gen.kCartesianVelocity, False)
        out, v, a = [], 0.0, 0.0
        for _ in range(600):
            a = min(a + 2000.0 * 1e-3, 8.0)
            v = min(v + a * 1e-3, 2.0)
            checker.judge({"O_dP_EE_c": [v, 0, 0, 0, 0, 0], "valid_elbow": False,
                           "elbow_c": [0.0, 0.0]}, 1, out)
        return sorted({e.name for e in out})

    assert errors(FR3) == []
    assert errors(FER) == ["cartesian_motion_generator_velocity_limits_violation"]


def test_a_pose_only_the_panda_reaches():
    """Joint 6 at 0.3 rad: inside the Panda's range, below the FR3's 0.54."""
    q = np.array(READY_POSE)
    q[5] = 0.3
    assert joint_limits(FER).ends_passed(joint_limits(FER).signed(q)) == []
    assert [i for i, _ in joint_limits(FR3).ends_passed(joint_limits(FR3).signed(q))] == [5]
