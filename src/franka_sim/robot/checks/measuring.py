"""The small measuring tools the command checks share: where samples fell in time, whether 16
numbers are a frame, and the rotation between two poses. Plain floats on 3-vectors: there they
beat numpy's per-call overhead several times over."""

from __future__ import annotations

import math

from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.robot.checks.figures import FRAME_TOLERANCE


class SampleGrid:
    """Where one signal's samples fell, in whole cycles; before the motion, 1 ms cycles at rest.

    A first difference over an interval belongs to its middle, so the next order divides by
    the distance between middles; on a uniform grid all three spacings are one cycle.
    """

    __slots__ = ("h1", "h0", "pending")

    def __init__(self) -> None:
        self.h1 = self.h0 = 1  # the last two intervals
        self.pending = 0  # cycles whose samples were skipped (not commanded, or invalid)

    def spacings(self, n: int) -> tuple[float, float, float]:
        """Seconds between the samples of the 0th, 1st and 2nd differences that end now."""
        return (n * CYCLE_PERIOD, (n + self.h1) * (CYCLE_PERIOD / 2),
                (n + 2 * self.h1 + self.h0) * (CYCLE_PERIOD / 4))

    def advance(self, n: int) -> None:
        self.h0, self.h1, self.pending = self.h1, n, 0


def frame_defect(m: list) -> tuple[float, float, str] | None:
    """None if 16 numbers (column-major 4×4) are a rigid transform, else (value, limit, quantity)
    saying why not: how far it is from one, or a rotation determinant of −1 (a mirror image)."""
    c0, c1, c2 = m[0:3], m[4:7], m[8:11]
    row = abs(m[3]) + abs(m[7]) + abs(m[11]) + abs(m[15] - 1.0)
    gram = max(abs(_dot(c0, c0) - 1.0), abs(_dot(c1, c1) - 1.0), abs(_dot(c2, c2) - 1.0),
               abs(_dot(c0, c1)), abs(_dot(c0, c2)), abs(_dot(c1, c2)))
    if not max(row, gram) <= FRAME_TOLERANCE:
        return max(row, gram), FRAME_TOLERANCE, "deviation from a rigid transform"
    det = _dot(c0, (c1[1] * c2[2] - c1[2] * c2[1], c1[2] * c2[0] - c1[0] * c2[2],
                    c1[0] * c2[1] - c1[1] * c2[0]))
    return None if det > 0.0 else (det, 1.0, "rotation determinant")


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def rotation_rows(m: list) -> tuple:
    """Rows of the rotation part of a 4×4 given as 16 numbers, column-major."""
    return (m[0], m[4], m[8]), (m[1], m[5], m[9]), (m[2], m[6], m[10])


def rotation_step(R0: tuple, R1: tuple) -> tuple[float, tuple[float, float, float]]:
    """Angle and base-frame unit axis of the rotation from R0 to R1 (rows), i.e. of R1·R0ᵀ.

    The angle is that of R0ᵀ·R1 too. It comes from the skew part and the trace via atan2, which
    keeps steps of a few µrad exact where acos of the trace would lose them to rounding.
    """
    wx = _dot(R1[2], R0[1]) - _dot(R1[1], R0[2])
    wy = _dot(R1[0], R0[2]) - _dot(R1[2], R0[0])
    wz = _dot(R1[1], R0[0]) - _dot(R1[0], R0[1])
    two_sin = math.sqrt(wx * wx + wy * wy + wz * wz)
    angle = math.atan2(two_sin, _dot(R1[0], R0[0]) + _dot(R1[1], R0[1]) + _dot(R1[2], R0[2]) - 1.0)
    if two_sin <= 1e-300:
        return angle, (0.0, 0.0, 0.0)
    return angle, (wx / two_sin, wy / two_sin, wz / two_sin)
