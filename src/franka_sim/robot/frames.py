"""Frame bookkeeping of the FCI: F (flange), NE (nominal EE, set in Desk), EE (setEE), K (setK).

O_T_EE = O_T_F · F_T_NE · NE_T_EE; the stiffness frame K hangs off EE via EE_T_K. The robot
reports all of them column-major; these helpers keep that convention in one place.
"""

from __future__ import annotations

import numpy as np

# Elbow flip angle of joint 4 (fr3_facts §1.1): elbow[1] is +1 above it, −1 below, 0 at it.
ELBOW_FLIP_Q4 = -0.467002423653011


def column_major(T: np.ndarray) -> np.ndarray:
    """16 numbers in the order the FCI puts a 4x4 matrix on the wire."""
    return np.asarray(T).ravel(order="F")


def elbow_of(q: np.ndarray) -> tuple[float, float]:
    """The elbow configuration (joint-3 angle, flip sign) of a joint vector, as the robot reports it."""
    q4 = float(q[3])
    flip = 1.0 if q4 > ELBOW_FLIP_Q4 else (-1.0 if q4 < ELBOW_FLIP_Q4 else 0.0)
    return float(q[2]), flip
