"""The elbow a Cartesian command may carry: elbow_c = (joint-3 angle, flip sign).

Judged only on cycles that command it (valid_elbow): otherwise elbow_c is zero fill, not a
signal. The first commanded angle must be the start elbow; the flip sign must never change;
the angle must stay in joint 3's range (an elbow beyond it is one the arm cannot take).
"""

from __future__ import annotations

import math

import numpy as np

from franka_sim.robot.checks.checker import CommandChecker, first_over
from franka_sim.robot.checks.figures import (
    ELBOW_MAGNITUDE, ELBOW_NAMES, ELBOW_SIGN_ERROR, ELBOW_START_ERROR, FR3,
    ELBOW_START_SIGN_ERROR, ELBOW_START_TOLERANCE, MotionFigures, derivative_thresholds,
)
from franka_sim.robot.checks.measuring import SampleGrid
from franka_sim.robot.checks.violation import Violation


class ElbowChecker(CommandChecker):
    """elbow_c against the start elbow (None: unknown, the first sample anchors the history)."""

    def __init__(self, elbow_start=None, figures: MotionFigures = FR3,
                 joint_range: tuple[float, float] = (-math.inf, math.inf)) -> None:
        self._envelope = figures.elbow
        self._lowest, self._highest = joint_range  # joint 3's, rad
        self._thr = derivative_thresholds(self._envelope, ELBOW_MAGNITUDE, 0)
        self._grid = SampleGrid()
        self._first = True
        self._start = None if elbow_start is None else [float(x) for x in elbow_start[:2]]
        self._elbow = None if elbow_start is None else (self._start[0], 0.0, 0.0)
        self._flip = 0.0 if elbow_start is None else _sign(self._start[1])

    def judge(self, command, n: int, out: list) -> None:
        first, self._first = self._first, False
        grid = self._grid
        if not command["valid_elbow"]:  # no elbow commanded: elbow_c is zero fill, not a signal
            grid.pending += n
            return
        position, flag = np.asarray(command["elbow_c"], dtype=float).tolist()[:2]
        start = self._start if first else None
        if start is not None and not abs(position - start[0]) <= ELBOW_START_TOLERANCE:
            out.append(Violation(ELBOW_START_ERROR, "elbow", abs(position - start[0]),
                                 ELBOW_START_TOLERANCE, quantity="start offset", unit="rad"))
            self._elbow = None  # reported; judge on from here
        sign = _sign(flag)
        if sign and self._flip and sign != self._flip:
            name = ELBOW_START_SIGN_ERROR if start is not None else ELBOW_SIGN_ERROR
            out.append(Violation(name, "elbow", sign, self._flip, quantity="sign"))
        self._flip = sign or self._flip
        if not self._lowest <= position <= self._highest:
            limit = self._highest if position > self._highest else self._lowest
            out.append(Violation(ELBOW_NAMES.velocity, "elbow", position, limit,
                                 quantity="position", unit="rad"))
        n += grid.pending
        if self._elbow is None:  # nothing to difference against: this sample anchors the history
            self._elbow = (position, 0.0, 0.0)
        else:
            s1, s2, s3 = grid.spacings(n)
            e0, v0, a0 = self._elbow
            v = (position - e0) / s1
            a = (v - v0) / s2
            j = (a - a0) / s3
            thr, env = self._thr, self._envelope
            if not (abs(v) <= thr[0] and abs(a) <= thr[1] and abs(j) <= thr[2]):
                first_over(out, ELBOW_NAMES, "elbow", "rad", (
                    (abs(a), thr[1], env.acceleration), (abs(j), thr[2], env.jerk),
                    (abs(v), thr[0], env.velocity)))
            self._elbow = (position, v, a)
        grid.advance(n)


def _sign(x: float) -> float:
    return math.copysign(1.0, x) if x else 0.0
