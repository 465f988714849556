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
