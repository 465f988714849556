"""The limit tables: the datasheet figures, libfranka's constants and the served URDF agree.

The published figures are restated here as data (the FR3 datasheet figures, and libfranka's
constants as docs/figures.md, "Joint and Cartesian limits", gives them), so a typo in the checks'
figures or in the URDF cannot hide behind the code that consumes it. The restatement itself is
checked against the same figures as tables in tests/data/fr3_limits.md, so a typo there shows too.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.robot.checks import figures as L
from franka_sim.robot.checks.joint_table import joint_limits
from franka_sim.robot.checks.measuring import frame_defect

DESC = load_arm_description(default_urdf_text())
FACTS = Path(__file__).resolve().parents[1] / "data" / "fr3_limits.md"

# FR3 datasheet figures (tests/data/fr3_limits.md, "Joint limits"), per joint: q range of
# libfranka's test URDF <limit> (pre-5.9), q̇ max, q̈ max, jerk max, τ max, τ̇ max.
JOINTS = [
    (-2.7501, 2.7501, 2.62, 10, 5000, 87, 1000),
    (-1.7918, 1.7918, 2.62, 10, 5000, 87, 1000),
    (-2.9065, 2.9065, 2.62, 10, 5000, 87, 1000),
    (-3.0481, -0.1458, 2.62, 10, 5000, 87, 1000),
    (-2.8101, 2.8101, 5.26, 10, 5000, 12, 1000),
    (0.54092, 4.5205, 4.18, 10, 5000, 12, 1000),
    (-3.0196, 3.0196, 5.26, 10, 5000, 12, 1000),
]
# tests/data/fr3_limits.md, "Position-based velocity limits", libfranka's set: deceleration,
# velocity offset, where the upper law reaches 0.
VELOCITY_LAW = [(6.0, 0.30, 2.7426), (2.585, 0.20, 1.7841), (3.5, 0.20, 2.9008),
                (4.0, 0.30, -0.1571), (17.0, 0.35, 2.8065), (5.5, 0.35, 4.5094),
                (17.0, 0.35, 3.0160)]
# tests/data/fr3_limits.md, "Cartesian limits": velocity, acceleration, jerk.
CARTESIAN = {"Translation": (3.0, 9.0, 4500), "Rotation": (2.5, 17, 8500),
             "Elbow": (2.62, 10, 5000)}
# docs/figures.md, "Joint and Cartesian limits": libfranka's rate-limiter constants (before its
# 1e-3 is subtracted), which must equal the robot's figures, except the elbow velocity it
# deliberately keeps lower.
LIBFRANKA = {"joint": (10, 5000), "torque rate": 1000, "translation": (3, 9, 4500),
             "rotation": (2.5, 17, 8500), "elbow": (1.5, 10, 5000)}


def test_fixed_figures_are_the_datasheet_ones():
    assert {(row[3], row[4], row[6]) for row in JOINTS} == {
        (L.JOINT_ACCELERATION, L.JOINT_JERK, L.TORQUE_RATE)}
    for envelope, key in ((L.CARTESIAN_TRANSLATION, "Translation"),
                          (L.CARTESIAN_ROTATION, "Rotation"), (L.ELBOW, "Elbow")):
        assert (envelope.velocity, envelope.acceleration, envelope.jerk) == CARTESIAN[key]


def test_libfrankas_limiter_uses_the_same_figures_so_what_it_produces_passes():
    assert (L.JOINT_ACCELERATION, L.JOINT_JERK) == LIBFRANKA["joint"]
    assert L.TORQUE_RATE == LIBFRANKA["torque rate"]
    for envelope, key in ((L.CARTESIAN_TRANSLATION, "translation"),
                          (L.CARTESIAN_ROTATION, "rotation")):
        assert (envelope.velocity, envelope.acceleration, envelope.jerk) == LIBFRANKA[key]
    # The elbow: libfranka limits itself to 1.5 rad/s; the robot's threshold is the datasheet's.
    assert L.ELBOW.velocity > LIBFRANKA["elbow"][0]
    assert (L.ELBOW.acceleration, L.ELBOW.jerk) == LIBFRANKA["elbow"][1:]
    assert L.LIBFRANKA_LIMIT_EPS == 1e-3


def test_per_joint_figures_come_from_the_served_urdf():
    table = joint_limits(DESC)
    expected = np.array(JOINTS, dtype=float)
    np.testing.assert_array_equal(table.lower, expected[:, 0])
    np.testing.assert_array_equal(table.upper, expected[:, 1])
    np.testing.assert_array_equal(table.velocity, expected[:, 2])
    np.testing.assert_array_equal(table.effort, expected[:, 5])
    law = np.array(VELOCITY_LAW)
    np.testing.assert_array_equal(table.deceleration, law[:, 0])
    np.testing.assert_array_equal(table.velocity_offset, law[:, 1])


def test_a_different_served_urdf_means_different_limits():
    text = default_urdf_text().replace('effort="87.0" velocity="2.62"',
                                       'effort="50.0" velocity="2.0"', 1)
    table = joint_limits(load_arm_description(text))
    assert (table.velocity[0], table.effort[0]) == (2.0, 50.0)
    assert joint_limits(DESC).velocity[0] == 2.62  # cached per description, not shared


def _law(q, lower, upper, v_max, decel, offset):
    """The law of docs/figures.md ("The position-based velocity limit law") written out per joint,
    independently of the vectorised table."""
    up = min(v_max, max(0.0, -offset + math.sqrt(max(0.0, 2 * decel * (upper - q)))))
    low = max(-v_max, min(0.0, offset - math.sqrt(max(0.0, 2 * decel * (q - lower)))))
    return low, up


def test_the_position_based_velocity_law_matches_its_published_form():
    table = joint_limits(DESC)
    rng = np.random.default_rng(7)
    for _ in range(200):
        q = rng.uniform(table.lower - 0.1, table.upper + 0.1)
        low, up = table.velocity_range(q)
        for i, ((lo_i, up_i, vmax, *_), (decel, offset, _)) in enumerate(zip(JOINTS, VELOCITY_LAW)):
            expected = _law(q[i], lo_i, up_i, vmax, decel, offset)
            assert (low[i], up[i]) == pytest.approx(expected, abs=1e-12)


def test_the_law_reaches_zero_where_the_fact_sheet_says():
    table = joint_limits(DESC)
    zero_at = np.array([row[2] for row in VELOCITY_LAW])
    _, up = table.velocity_range(zero_at - 1e-4)
    assert np.all((up > 0) & (up < 0.02))
    _, up = table.velocity_range(zero_at + 1e-4)
    np.testing.assert_array_equal(up, 0.0)
    low, up = table.velocity_range((table.lower + table.upper) / 2)
    assert np.all(up == table.velocity) and np.all(low == -table.velocity)


def test_the_float32_echo_slack_is_a_few_percent_at_most():
    assert L.float32_half_ulp(8.0) == 2.0**-22  # joint angles below 8 rad
    assert L.float32_half_ulp(2.0) == 2.0**-24
    joint = L.Envelope(0.0, L.JOINT_ACCELERATION, L.JOINT_JERK)
    _, acceleration, jerk = L.derivative_thresholds(joint, L.JOINT_POSITION_MAGNITUDE, 0)
    assert acceleration / L.JOINT_ACCELERATION - 1 < 0.03 and jerk / L.JOINT_JERK - 1 < 0.05
    for envelope in (L.CARTESIAN_TRANSLATION, L.CARTESIAN_ROTATION):
        slack = np.array(L.derivative_thresholds(envelope, L.CARTESIAN_POSITION_MAGNITUDE, 0))
        limits = np.array([envelope.velocity, envelope.acceleration, envelope.jerk])
        assert np.all(slack / limits - 1 < 0.015)
    assert L.echo_slack(L.TORQUE_MAGNITUDE, 1) < 0.01 * L.TORQUE_RATE


def test_the_frame_check_accepts_rigid_transforms_only():
    T = np.eye(4)
    T[:3, 3] = (0.3, 0.0, 0.5)
    assert frame_defect(T.ravel(order="F").tolist()) is None
    assert frame_defect(T.astype(np.float32).astype(float).ravel(order="F").tolist()) is None
    assert frame_defect([0.0] * 16)[2] == "deviation from a rigid transform"
    mirrored = np.diag([-1.0, 1.0, 1.0, 1.0])
    assert frame_defect(mirrored.ravel(order="F").tolist())[:2] == (-1.0, 1.0)


# -- the restatement above against the tables of tests/data ----------------------------------------------
def _table(text: str, header_start: str) -> list[list[str]]:
    """Rows of the first markdown table whose header line starts with `header_start`."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().startswith(header_start))
    rows = []
    for line in lines[start + 2:]:
        if not line.strip().startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def _numbers(cell: str) -> list[float]:
    cell = cell.replace("−", "-")
    values = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", cell)]
    return [-values[0], values[0]] if cell.startswith("±") else values


def test_the_restated_figures_are_those_of_the_datasheet():
    text = FACTS.read_text(encoding="utf-8")
    joints = _table(text, "| Joint | q min/max")
    assert len(joints) == 7
    for row, expected in zip(joints, JOINTS):
        assert _numbers(row[1]) == list(expected[:2])  # the libfranka test URDF <limit> range
        assert [float(x) for x in row[2:7]] == list(expected[2:])
    law = _table(text, "| Joint | q̈dec")
    assert len(law) == 7
    for row, (decel, offset, zero_at) in zip(law, VELOCITY_LAW):
        assert (float(row[1]), float(row[2]), _numbers(row[3])[0]) == (decel, offset, zero_at)
    cartesian = {row[0]: tuple(_numbers(" ".join(row[1:])))
                 for row in _table(text, "| Quantity | Velocity")}
    assert cartesian == CARTESIAN


def test_every_abort_is_logged_and_a_tolerated_violation_thinned(caplog):
    from franka_sim.robot.checks.violation import Violation, ViolationLog

    jerk = Violation("joint_motion_generator_acceleration_discontinuity", "joint 4", 6000.0,
                     5000.0, quantity="jerk", unit="rad/s³")
    for enforced, lines in ((True, 12), (False, 2)):  # (thinned: the 1st and the 10th)
        caplog.clear()
        violations = ViolationLog()
        with caplog.at_level("WARNING"):
            for _ in range(12):
                violations.report([jerk], enforced)
        assert len(caplog.records) == lines
    assert caplog.records[0].getMessage().endswith("(not enforced; 1 so far)")
