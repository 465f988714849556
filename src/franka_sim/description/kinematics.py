"""Forward kinematics in plain numpy, straight from an ArmDescription.

This is the reference the MuJoCo scene is tested against, and what the robot core can use
without touching the physics thread (e.g. to fill O_T_EE_d from a commanded q). It is not on
the 1 kHz path, so it favours obviousness over speed.
"""

from __future__ import annotations

import math

import numpy as np

from franka_sim.description.urdf import FLANGE_LINK, ArmDescription

# Joint-4 angle at which the elbow flips: elbow[1] is +1 above, −1 below (docs/figures.md,
# "Kinematics (modified DH)").
ELBOW_FLIP_Q4 = -0.467002423653011


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """4x4 rotation by `angle` about the unit `axis` (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    transform = np.eye(4)
    transform[:3, :3] = [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
    return transform


def fk_frames(desc: ArmDescription, q) -> list[np.ndarray]:
    """Base-frame poses of the seven joint frames (links 1..7), each after its joint's rotation."""
    q = np.asarray(q, dtype=float)
    if q.shape != (len(desc.joints),):
        raise ValueError(f"q must have shape ({len(desc.joints)},), got {q.shape}")
    bodies = [np.eye(4)]  # body 0: the fixed base
    for joint, angle in zip(desc.joints, q):
        parent = desc.frames[joint.parent]
        bodies.append(bodies[parent.body] @ parent.offset @ joint.origin
                      @ axis_rotation(joint.axis, angle))
    return bodies[1:]


def frame_pose(desc: ArmDescription, q, name: str) -> np.ndarray:
    """Base-frame pose of any link of the description (fixed frames included) at q."""
    try:
        frame = desc.frames[name]
    except KeyError:
        raise KeyError(f"no frame {name!r} in the description") from None
    if frame.body == 0:
        return np.array(frame.offset)
    return fk_frames(desc, q)[frame.body - 1] @ frame.offset


def flange_pose(desc: ArmDescription, q) -> np.ndarray:
    """O_T_F: base → flange (link8)."""
    return frame_pose(desc, q, FLANGE_LINK)


def elbow(q) -> tuple[float, float]:
    """The robot's elbow pair: (q3, sign of q4 relative to the flip angle; 0 exactly at it)."""
    q4 = float(q[3])
    flag = 0.0 if q4 == ELBOW_FLIP_Q4 else (1.0 if q4 > ELBOW_FLIP_Q4 else -1.0)
    return float(q[2]), flag


def tip_jacobian(desc: ArmDescription, q, F_T_tip=None) -> np.ndarray:
    """(6,7) base-frame Jacobian [linear; angular] of a point fixed to the flange (F_T_tip).

    Geometric, from the joint frames: column i is (z_i × (p_tip − p_i), z_i) for a revolute
    joint turning about its local axis. Used off the hot path (e.g. the singular-start check).
    """
    frames = fk_frames(desc, q)
    tip = flange_pose(desc, q) @ (np.eye(4) if F_T_tip is None else F_T_tip)
    J = np.zeros((6, len(frames)))
    for i, (joint, T) in enumerate(zip(desc.joints, frames)):
        z = T[:3, :3] @ joint.axis
        J[:3, i] = np.cross(z, tip[:3, 3] - T[:3, 3])
        J[3:, i] = z
    return J
