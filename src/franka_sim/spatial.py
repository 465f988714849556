"""Small spatial helpers shared by the physics, the checks and the state.

Pure numpy on 3-vectors and 4×4 transforms. The hand-written cross product exists because
`np.cross` costs ~10 µs on 3-vectors and the hot path calls it every cycle; this costs ~1.
"""

from __future__ import annotations

import numpy as np


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
    twist = J_F @ dq
    rx, ry, rz = (O_T_F[:3, :3] @ F_T_P[:3, 3]).tolist()
    vx, vy, vz, wx, wy, wz = twist.tolist()
    twist[0] = vx + (wy * rz - wz * ry)
    twist[1] = vy + (wz * rx - wx * rz)
    twist[2] = vz + (wx * ry - wy * rx)
    return twist
