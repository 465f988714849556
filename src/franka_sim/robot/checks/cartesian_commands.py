"""The Cartesian interfaces' command streams: O_T_EE_c (pose) and O_dP_EE_c (twist).

Translation and rotation are each judged by the norms of their rate and its next two
differences against the FR3's Cartesian envelopes. The pose's history starts at rest at
O_T_EE_start, the pose the state showed as the motion began: the first command must be that
pose. A pose that is not a frame is reported and skipped; the next valid one is judged against
the last valid one.
"""

from __future__ import annotations

import math

import numpy as np

from franka_sim.robot.checks.checker import CommandChecker, first_over
from franka_sim.robot.checks.figures import (
    CARTESIAN_POSE_NAMES, CARTESIAN_POSITION_MAGNITUDE, FR3,
    CARTESIAN_START_ERROR, CARTESIAN_START_ROTATION_TOLERANCE,
    CARTESIAN_START_TRANSLATION_TOLERANCE, CARTESIAN_VELOCITY_NAMES, MotionFigures,
    INVALID_FRAME_ERROR, TWIST_MAGNITUDE, derivative_thresholds,
)
from franka_sim.robot.checks.measuring import (
    SampleGrid, frame_defect, rotation_rows, rotation_step,
)
from franka_sim.robot.checks.violation import Violation

_AT_REST = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # a 3-vector rate and its rate, both zero


class CartesianPoseChecker(CommandChecker):
    """O_T_EE_c (4×4, or 16 numbers column-major, from O_T_EE_start on)."""

    def __init__(self, O_T_EE_start, figures: MotionFigures = FR3) -> None:
        if O_T_EE_start is None:
            raise ValueError("a Cartesian pose motion needs O_T_EE_start")
        self._translation, self._rotation = figures.translation, figures.rotation
        self._t_thr = derivative_thresholds(self._translation, CARTESIAN_POSITION_MAGNITUDE, 0)
        self._r_thr = derivative_thresholds(self._rotation, CARTESIAN_POSITION_MAGNITUDE, 0)
        self._lin = self._ang = _AT_REST
        self._grid = SampleGrid()
        self._first = True
        T = np.asarray(O_T_EE_start, dtype=float)
        m = (T.ravel(order="F") if T.shape == (4, 4) else T.ravel()).tolist()
        self._R, self._p = rotation_rows(m), (m[12], m[13], m[14])

    def judge(self, command, n: int, out: list) -> None:
        first, self._first = self._first, False
        m = np.asarray(command["O_T_EE_c"], dtype=float).tolist()
        defect = frame_defect(m)
        if defect is not None:
            value, limit, quantity = defect
            out.append(Violation(INVALID_FRAME_ERROR, "frame", value, limit, quantity=quantity))
            self._grid.pending += n  # the next valid pose is judged against the last valid one
            return
        n += self._grid.pending
        s1, s2, s3 = self._grid.spacings(n)
        R, p, P = rotation_rows(m), (m[12], m[13], m[14]), self._p
        lin = ((p[0] - P[0]) / s1, (p[1] - P[1]) / s1, (p[2] - P[2]) / s1)
        angle, axis = rotation_step(self._R, R)
        if first and self._start_invalid(math.hypot(*lin) * s1, angle, out):
            self._lin = self._ang = _AT_REST
        else:
            self._lin = _rates(out, CARTESIAN_POSE_NAMES, "translation", "m", lin, self._lin,
                               s2, s3, self._t_thr, self._translation)
            omega = (axis[0] * angle / s1, axis[1] * angle / s1, axis[2] * angle / s1)
            self._ang = _rates(out, CARTESIAN_POSE_NAMES, "rotation", "rad", omega, self._ang,
                               s2, s3, self._r_thr, self._rotation, speed=angle / s1)
        self._R, self._p = R, p
        self._grid.advance(n)

    @staticmethod
    def _start_invalid(offset: float, angle: float, out: list) -> bool:
        before = len(out)
        for axis, value, tolerance, unit in (
                ("translation", offset, CARTESIAN_START_TRANSLATION_TOLERANCE, "m"),
                ("rotation", angle, CARTESIAN_START_ROTATION_TOLERANCE, "rad")):
            if not value <= tolerance:
                out.append(Violation(CARTESIAN_START_ERROR, axis, value, tolerance,
                                     quantity="start offset", unit=unit))
        return len(out) > before


class CartesianVelocityChecker(CommandChecker):
    """O_dP_EE_c, from rest."""

    def __init__(self, figures: MotionFigures = FR3) -> None:
        self._translation, self._rotation = figures.translation, figures.rotation
        self._t_thr = derivative_thresholds(self._translation, TWIST_MAGNITUDE, 1)
        self._r_thr = derivative_thresholds(self._rotation, TWIST_MAGNITUDE, 1)
        self._lin = self._ang = _AT_REST
        self._grid = SampleGrid()

    def judge(self, command, n: int, out: list) -> None:
        twist = np.asarray(command["O_dP_EE_c"], dtype=float).tolist()
        s1, s2, _ = self._grid.spacings(n)
        names = CARTESIAN_VELOCITY_NAMES
        self._lin = _rates(out, names, "translation", "m", twist[:3], self._lin, s1, s2,
                           self._t_thr, self._translation)
        self._ang = _rates(out, names, "rotation", "rad", twist[3:], self._ang, s1, s2,
                           self._r_thr, self._rotation)
        self._grid.advance(n)


def _rates(out, names, axis, unit, vel, previous, s_a, s_j, thresholds, envelope, speed=None):
    """Judge a 3-vector rate and its next two differences by their norms; the new history."""
    v0, a0 = previous
    acc = ((vel[0] - v0[0]) / s_a, (vel[1] - v0[1]) / s_a, (vel[2] - v0[2]) / s_a)
    jerk = ((acc[0] - a0[0]) / s_j, (acc[1] - a0[1]) / s_j, (acc[2] - a0[2]) / s_j)
    speed = math.hypot(*vel) if speed is None else speed
    a_norm, j_norm = math.hypot(*acc), math.hypot(*jerk)
    if not (speed <= thresholds[0] and a_norm <= thresholds[1] and j_norm <= thresholds[2]):
        first_over(out, names, axis, unit, (
            (a_norm, thresholds[1], envelope.acceleration), (j_norm, thresholds[2], envelope.jerk),
            (speed, thresholds[0], envelope.velocity)))
    return tuple(vel), acc
