"""The served FR3 description: what libfranka requires of it, and that it is the FR3.

Expected figures are restated here as data (tests/data/fr3_limits.md, and docs/figures.md: the
kinematics, link masses, accelerometer frames and the served URDF's rules) and the kinematics are
checked against an independent modified-DH chain, so a typo in the URDF or in the parser cannot
hide behind the code that consumes it.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from franka_sim.description import hand
from franka_sim.description.kinematics import ELBOW_FLIP_Q4, elbow, fk_frames, flange_pose, frame_pose
from franka_sim.description.urdf import DescriptionError, default_urdf_text, load_arm_description

URDF = default_urdf_text()
PI = math.pi

# tests/data/fr3_limits.md: lower, upper, velocity, effort, deceleration, velocity offset.
LIMITS = [
    (-2.7501, 2.7501, 2.62, 87, 6.0, 0.30),
    (-1.7918, 1.7918, 2.62, 87, 2.585, 0.20),
    (-2.9065, 2.9065, 2.62, 87, 3.50, 0.20),
    (-3.0481, -0.1458, 2.62, 87, 4.00, 0.30),
    (-2.8101, 2.8101, 5.26, 12, 17.0, 0.35),
    (0.54092, 4.5205, 4.18, 12, 5.5, 0.35),
    (-3.0196, 3.0196, 5.26, 12, 17.0, 0.35),
]
DATASHEET = [(-2.9007, 2.9007), (-1.8361, 1.8361), (-2.9007, 2.9007), (-3.0770, -0.1169),
             (-2.8763, 2.8763), (0.4398, 4.6216), (-3.0508, 3.0508)]
# docs/figures.md, "Kinematics (modified DH)": (a, d, alpha) per joint, then the flange.
DH = [(0, 0.333, 0), (0, 0, -PI / 2), (0, 0.316, PI / 2), (0.0825, 0, PI / 2),
      (-0.0825, 0.384, -PI / 2), (0, 0, PI / 2), (0.088, 0, PI / 2)]
FLANGE_D = 0.107
# docs/figures.md, "Link masses and inertials": masses, links 0..7.
MASSES = [2.3966, 2.92747, 2.93554, 2.24490, 2.61560, 2.32712, 1.81704, 0.627143]
# docs/figures.md, "Accelerometer frames": (xyz, roll) of each frame in its link, top then bottom.
ACCELEROMETERS = {
    0: (((0, 0, 0.05), PI), ((0, 0, 0.06), 0)),
    1: (((0, -0.10, 0), PI / 2), ((0, -0.09, 0), -PI / 2)),
    2: (((0, -0.13, 0), -PI / 2), ((0, -0.14, 0), PI / 2)),
    3: (((0.0825, 0.05, 0), -PI / 2), ((0.0825, 0.04, 0), PI / 2)),
    4: (((-0.0825, 0.05, 0), PI / 2), ((-0.0825, 0.06, 0), -PI / 2)),
    5: (((0, 0.11, 0), -PI / 2), ((0, 0.10, 0), PI / 2)),
}
HOME = np.array([0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4])


def dh_chain(q) -> list[np.ndarray]:
    """Independent FK: T_i = RotX(alpha) TransX(a) RotZ(q_i) TransZ(d), then the flange."""
    frames, T = [], np.eye(4)
    for (a, d, alpha), qi in zip(DH + [(0, FLANGE_D, 0)], list(q) + [0.0]):
        ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(qi), math.sin(qi)
        T = T @ np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa],
                          [st * sa, ct * sa, ca, d * ca], [0, 0, 0, 1]])
        frames.append(T)
    return frames


@pytest.fixture(scope="module")
def desc():
    return load_arm_description(URDF)


def random_poses(desc, n, seed=1):
    rng = np.random.default_rng(seed)
    return [rng.uniform(desc.lower, desc.upper) for _ in range(n)]


# -- docs/figures.md, "What libfranka requires of the served URDF", checked on the XML itself --
def test_served_urdf_satisfies_libfranka_rules():
    robot = ET.fromstring(URDF)
    assert robot.tag == "robot" and robot.get("name") == "fr3"
    assert not robot.get("name").startswith("tmr")
    assert "link8" in {link.get("name") for link in robot.findall("link")}
    joints = robot.findall("joint")
    for i in range(1, 8):
        matching = [j for j in joints if f"joint{i}" in j.get("name")]
        assert [j.get("name") for j in matching] == [f"joint{i}"]  # and no other joint contains it
        limit = matching[0].find("limit")
        pbvl = matching[0].find("position_based_velocity_limits")
        assert all(limit.get(a) is not None for a in ("velocity", "upper", "lower"))
        assert all(pbvl.get(a) is not None for a in ("velocity_offset", "deceleration_limit"))
    movable = [j.get("name") for j in joints if j.get("type") != "fixed"]
    assert movable == [f"joint{i}" for i in range(1, 8)]
    flange = next(j for j in joints if j.find("child").get("link") == "link8")
    assert flange.get("type") == "fixed" and flange.find("parent").get("link") == "link7"
    assert flange.find("origin").get("xyz").split() == ["0", "0", "0.107"]
    assert not list(robot.iter("mesh")) and "xacro" not in URDF


def test_limits_match_protocol_table(desc):
    assert desc.joint_names == tuple(f"joint{i}" for i in range(1, 8))
    for joint, row, soft in zip(desc.joints, LIMITS, DATASHEET):
        lim = joint.limits
        got = (lim.lower, lim.upper, lim.velocity, lim.effort, lim.deceleration_limit,
               lim.velocity_offset)
        assert got == pytest.approx(row, abs=1e-12), joint.name
        assert (lim.soft_lower, lim.soft_upper) == pytest.approx(soft, abs=1e-12)


def test_inertials_are_the_fr3_figures(desc):
    for i, mass in enumerate(MASSES):
        inertial = desc.inertials[f"link{i}"]
        assert inertial.mass == pytest.approx(mass, rel=2e-5)
        assert np.allclose(inertial.inertia, inertial.inertia.T)
        assert np.all(np.linalg.eigvalsh(inertial.inertia) > 0)
    assert sum(desc.inertials[f"link{i}"].mass for i in range(1, 8)) == pytest.approx(15.49, abs=0.01)
    assert desc.inertials["link4"].inertia[0, 1] == pytest.approx(0.013226, rel=1e-4)
    assert "link8" not in desc.inertials


def test_accelerometer_frames(desc):
    for i, frames in ACCELEROMETERS.items():
        for suffix, (xyz, roll) in zip(("top", "bottom"), frames):
            frame = desc.frames[f"link{i}_accelerometer_{suffix}"]
            assert frame.body == i
            expected = np.eye(4)
            c, s = math.cos(roll), math.sin(roll)
            expected[:3, :3] = [[1, 0, 0], [0, c, -s], [0, s, c]]
            expected[:3, 3] = xyz
            assert np.allclose(frame.offset, expected, atol=1e-12)


# -- kinematics -----------------------------------------------------------------------------------
def test_fk_matches_modified_dh(desc):
    for q in [np.zeros(7), HOME] + random_poses(desc, 10):
        reference = dh_chain(q)
        ours = fk_frames(desc, q)
        for k in range(7):
            assert np.allclose(ours[k], reference[k], atol=1e-12)
        assert np.allclose(flange_pose(desc, q), reference[7], atol=1e-12)


def test_flange_at_zero_pose():
    # Stretched arm: flange 0.088 forward, 0.333 + 0.316 + 0.384 − 0.107 up, pointing down.
    pose = flange_pose(load_arm_description(URDF), np.zeros(7))
    assert np.allclose(pose[:3, 3], [0.088, 0, 0.333 + 0.316 + 0.384 - 0.107], atol=1e-12)
    assert np.allclose(pose[:3, :3], np.diag([1, -1, -1]), atol=1e-12)


def test_fixed_frames(desc):
    q = HOME
    top1 = frame_pose(desc, q, "link1_accelerometer_top")
    assert np.allclose(top1, fk_frames(desc, q)[0] @ desc.frames["link1_accelerometer_top"].offset)
    assert np.allclose(frame_pose(desc, q, "link0_accelerometer_bottom")[:3, 3], [0, 0, 0.06])
    with pytest.raises(KeyError):
        frame_pose(desc, q, "link9")


def test_elbow_flag():
    q = HOME.copy()
    assert elbow(q) == (0.0, -1.0)
    q[2], q[3] = 0.3, -0.2
    assert elbow(q) == (0.3, 1.0)
    q[3] = ELBOW_FLIP_Q4
    assert elbow(q) == (0.3, 0.0)


# -- rejection of what libfranka would reject -------------------------------------------------------
def _edited(old: str, new: str) -> str:
    assert old in URDF
    return URDF.replace(old, new, 1)


@pytest.mark.parametrize("text, message", [
    (_edited('<robot name="fr3">', '<robot name="tmr_fr3">'), "tmr"),
    (_edited('<position_based_velocity_limits velocity_offset="0.35" deceleration_limit="5.5"/>',
             ""), "position_based_velocity_limits"),
    (_edited('lower="-1.7918" upper', 'upper'), "lower"),
    (_edited('<link name="link8"/>', '<link name="flange"/>').replace(
        '<child link="link8"/>', '<child link="flange"/>'), "link8"),
    (_edited('<joint name="joint7" type="revolute">', '<joint name="joint7" type="fixed">'),
     "revolute"),
    (_edited('<joint name="joint3" type="revolute">', '<joint name="elbow3" type="revolute">'),
     "joint3"),
    (_edited("</robot>", '<link name="finger"/><joint name="fr3_finger_joint1" type="prismatic">'
             '<parent link="link8"/><child link="finger"/></joint></robot>'), "joint1"),
    ("<robot name='fr3'><link", "well-formed"),
    ("<model/>", "<robot>"),
])
def test_rejects_what_libfranka_rejects(text, message):
    with pytest.raises(DescriptionError, match=message):
        load_arm_description(text)


def test_default_text_is_the_repository_file():
    from pathlib import Path

    repo_file = Path(__file__).resolve().parents[2] / "urdf" / "fr3.urdf"
    assert default_urdf_text() == repo_file.read_text(encoding="utf-8")


# -- the Hand's reported figures --------------------------------------------------------------------
def test_hand_figures():
    column_major = [0.7071, -0.7071, 0, 0, 0.7071, 0.7071, 0, 0, 0, 0, 1, 0, 0, 0, 0.1034, 1]
    assert np.allclose(hand.F_T_NE_HAND.T.ravel(), column_major, atol=1e-4)
    assert hand.HAND_MASS == 0.73
    assert np.allclose(hand.HAND_COM, [-0.01, 0, 0.03])
    assert np.allclose(hand.HAND_INERTIA, np.diag([0.001, 0.0025, 0.0017]))


def test_combine_inertials():
    m, c, inertia = hand.combine_inertials(hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA,
                                           0.0, [0, 0, 0], np.zeros((3, 3)))
    assert m == 0.73 and np.allclose(c, hand.HAND_COM) and np.allclose(inertia, hand.HAND_INERTIA)
    # Two 1 kg points 0.2 m apart on x: CoM between them, I_yy = I_zz = 2·1·0.1².
    m, c, inertia = hand.combine_inertials(1, [0.1, 0, 0], np.zeros((3, 3)),
                                           1, [-0.1, 0, 0], np.zeros((3, 3)))
    assert m == 2 and np.allclose(c, 0) and np.allclose(inertia, np.diag([0, 0.02, 0.02]))
