"""Small spatial helpers shared by the physics, the robot's IK and controllers, and the state.

Pure numpy on 3-vectors, rotations and 4×4 transforms. Several avoid numpy's general routines
on purpose (floats via `tolist`, hand-written products): at 3×3 the wrappers cost more than the
arithmetic, and these run every cycle. The hand-written cross product exists because
`np.cross` costs ~10 µs on 3-vectors and the hot path calls it every cycle; this costs ~1.
"""

from __future__ import annotations

import math

import numpy as np

_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for 3-vectors, as a fresh array."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def column_major(T: np.ndarray) -> np.ndarray:
    """16 numbers in the order the FCI puts a 4×4 matrix on the wire."""
    return np.asarray(T).ravel(order="F")


def point_twist(O_T_F: np.ndarray, J_F: np.ndarray, F_T_P: np.ndarray,
                dq: np.ndarray) -> np.ndarray:
    """Twist (v; ω) in the base frame of the point F_T_P rigidly attached to the flange, from
    the flange Jacobian: v_P = v_F + ω × r. The cross product is written out in floats (see
    the module docstring)."""
    twist = np.dot(J_F, dq)  # (`@` gives the same bits, ~0.25 µs slower on small arrays)
    rx, ry, rz = (O_T_F[:3, :3] @ F_T_P[:3, 3]).tolist()
    vx, vy, vz, wx, wy, wz = twist.tolist()
    twist[0] = vx + (wy * rz - wz * ry)
    twist[1] = vy + (wz * rx - wx * rz)
    twist[2] = vz + (wx * ry - wy * rx)
    return twist


def skew(v: np.ndarray) -> np.ndarray:
    x, y, z = v.tolist() if isinstance(v, np.ndarray) else v  # floats build ~2× faster
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The axis·angle of a rotation matrix (log map), robust near 0 and π."""
    cos = min(max((R.trace() - 1.0) / 2.0, -1.0), 1.0)  # np.clip, without its ~2 µs wrapper
    angle = np.arccos(cos)
    r0, r1, r2 = R.tolist()
    w = np.array([r2[1] - r1[2], r0[2] - r2[0], r1[0] - r0[1]])
    if angle < 1e-9:
        return 0.5 * w
    if np.pi - angle < 1e-6:
        axis = np.sqrt(np.maximum((np.diag(R) + 1.0) / 2.0, 0.0))
        axis *= np.where(w >= 0, 1.0, -1.0)
        return angle * axis / max(np.linalg.norm(axis), 1e-12)
    return angle / (2.0 * np.sin(angle)) * w


def exp_rotation(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    angle = math.sqrt(w.dot(w))  # np.linalg.norm's own sum, without its checks
    if angle < 1e-12:
        return _EYE3 + skew(w)
    K = skew(w / angle)
    return _EYE3 + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def pose_error(T_target: np.ndarray, T: np.ndarray) -> np.ndarray:
    """[translation; rotation vector] taking T to T_target, in the base frame."""
    return np.concatenate([T_target[:3, 3] - T[:3, 3], rotation_vector(T_target[:3, :3] @ T[:3, :3].T)])


def pose_in_base(pose: np.ndarray, base: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """A world-frame 4×4 pose expressed in an arm's base frame, in place (and returned); `base`
    is the base's (R, p) in the world."""
    R, p = base
    pose[:3, :3] = R.T @ pose[:3, :3]
    pose[:3, 3] = R.T @ (pose[:3, 3] - p)
    return pose


def jacobian_in_base(J: np.ndarray, base: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """A world-frame 6×n Jacobian (linear rows, then angular) in an arm's base frame."""
    R = base[0]
    return np.vstack([R.T @ J[:3], R.T @ J[3:]])
