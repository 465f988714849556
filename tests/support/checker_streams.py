"""Command streams for the motion-limit checker's tests (tests/robot/test_safety*.py): crafted
RobotCommand records at 1 ms cycles, the checkers they go through, and what they reported."""

from __future__ import annotations

import math

import numpy as np

from franka_sim.description.kinematics import elbow, flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.protocol.codec import decode_command, encode_command
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.robot.checks import Violation, command_checker_for

DESC = load_arm_description(default_urdf_text())
DT = 1e-3
HOME = np.array([0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4])
T_HOME = flange_pose(DESC, HOME)
ELBOW_HOME = elbow(HOME)  # (joint-3 angle, flip sign −1 at this pose)

JP = JV = "joint_motion_generator_"  # (position / velocity interface, for readability)
CART = "cartesian_motion_generator_"


def column_major(T) -> np.ndarray:
    return np.asarray(T).ravel(order="F")


def command(**fields):
    """A RobotCommand exactly as the server decodes it: every other field zero."""
    return decode_command(encode_command(**fields))


def joint_checker(generator=Gen.kJointPosition, torque=False, q_start=HOME):
    return command_checker_for(DESC, generator, torque, q_start=q_start, O_T_EE_start=None,
                               elbow_start=None)


def cartesian_checker(generator=Gen.kCartesianPosition, torque=False, elbow=ELBOW_HOME):
    return command_checker_for(DESC, generator, torque, q_start=HOME, O_T_EE_start=T_HOME,
                               elbow_start=elbow)


def run(checker, commands, cycles=None) -> list[tuple[int, Violation]]:
    """Feed a stream; (index, violation) for everything reported."""
    cycles = cycles or [1] * len(commands)
    return [(k, v) for k, (c, n) in enumerate(zip(commands, cycles)) for v in checker.check(c, n)]


def names(reported) -> set[str]:
    return {v.name for _, v in reported}


def fields(reported, *attributes) -> list[tuple]:
    """The chosen attributes of each reported violation, in order."""
    return [tuple(getattr(v, a) for a in attributes) for _, v in reported]


# -- profiles ---------------------------------------------------------------------------------
def quintic(t, duration):
    """Rest-to-rest 0→1 with zero velocity and acceleration at both ends; peak ä = 5.7735/T²."""
    s = np.clip(np.asarray(t, dtype=float) / duration, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def quintic_duration(distance, peak_acceleration):
    return math.sqrt(5.773502691896258 * distance / peak_acceleration)


def joint_quintic(fraction=0.95, distance=1.0, joints=(0, 3)):
    """A joint-position stream whose peak acceleration is `fraction` of 10 rad/s² (1 ms cycles)."""
    duration = quintic_duration(distance, 10.0 * fraction)
    t = np.arange(1, int(duration / DT) + 200) * DT
    q = np.tile(HOME, (len(t), 1))
    for i in joints:
        q[:, i] += distance * quintic(t, duration)
    return q


def pose(translation=(0.0, 0.0, 0.0), angle=0.0, T=T_HOME):
    """T_HOME moved by a base-frame translation and a rotation about the base z axis."""
    c, s = math.cos(angle), math.sin(angle)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    out = T.copy()
    out[:3, :3] = Rz @ T[:3, :3]
    out[:3, 3] = T[:3, 3] + np.asarray(translation)
    return out


def pose_commands(poses, **extra):
    return [command(O_T_EE_c=column_major(P), **extra) for P in poses]


def ramp(peak, rise, hold, start=0.0):
    """Velocity from rest to `peak` by a half-cosine over `rise` s, then held for `hold` s."""
    t = np.arange(1, int((rise + hold) / DT) + 1) * DT
    v = peak * 0.5 * (1 - np.cos(math.pi * np.minimum(t, rise) / rise))
    return start + np.cumsum(v) * DT, v

