"""The joint side of Cartesian commands: the IK output is held to the joint limits (27–30)."""

from __future__ import annotations

import numpy as np

from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.robot.checks import IkJointSideChecker
from franka_sim.robot.motion import JointReference

DESC = load_arm_description(default_urdf_text())
PREFIX = "cartesian_motion_generator_joint_"


def _names(checker, ref):
    return {v.name.removeprefix(PREFIX) for v in checker.check(ref)}


def test_a_smooth_slow_ik_output_passes():
    checker, ref = IkJointSideChecker(DESC), JointReference(np.array(READY_POSE))
    for k in range(200):
        ref.follow_position(np.array(READY_POSE) + 0.05 * (1 - np.cos(np.pi * k / 199)) / 2)
        assert not checker.check(ref)


def test_each_joint_side_error_is_named():
    checker, ref = IkJointSideChecker(DESC), JointReference(np.array(READY_POSE))
    q = np.array(READY_POSE)
    ref.follow_position(q + [0, 0, 0, 0, 0, 0, 0.001])  # 1 rad/s in one cycle: accel 1000
    assert _names(checker, ref) >= {"velocity_discontinuity", "acceleration_discontinuity"}
    fast = JointReference(q)
    fast.dq_d = np.array([0, 0, 0, 0, 0, 0, 6.0])  # over joint 7's 5.26 rad/s
    assert "velocity_limits_violation" in _names(IkJointSideChecker(DESC), fast)
    out = JointReference(q)
    out.q_d = q + [0, 0, 0, 0, 0, 0, 3.0]  # past joint 7's end
    assert "position_limits_violation" in _names(IkJointSideChecker(DESC), out)


def test_the_scale_scales_the_envelope():
    ref = JointReference(np.array(READY_POSE))
    ref.follow_position(np.array(READY_POSE) + [0, 0, 0, 0, 0, 0, 2e-6])  # accel 2 rad/s²
    assert not IkJointSideChecker(DESC, scale=1.0).check(ref)
    assert "velocity_discontinuity" in _names(IkJointSideChecker(DESC, scale=0.1), ref)
