"""The joint interfaces' command streams: q_c (joint position) and dq_c (joint velocity).

Both are held to the URDF range and velocity law (joint_table.py) and the joint acceleration
and jerk limits, on signed 14-vectors [x, −x] (see JointLimitTable). Each signal's history
starts at rest at q_start, the start the robot holds (what the state showed as the motion
began): the first command must equal it, and the stream must accelerate from zero.

The usual in-limits cycle is proven inside every limit against a SpeedLimitFloor laid at the
previous command (where the law applies): one comparison of the stacked [next start,
velocity − floor, acceleration, jerk] against their thresholds. Only when that fails is the
law evaluated and the step explained; the floor then moves to the new start. Either way the
verdict is the law's own (see SpeedLimitFloor).
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.kernels import joint_position_step
from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.robot.checks.checker import CommandChecker, first_over
from franka_sim.robot.checks.figures import (
    JOINT_POSITION_MAGNITUDE, JOINT_POSITION_NAMES, JOINT_RANGE_ERROR, JOINT_START_ERROR,
    JOINT_START_TOLERANCE, JOINT_VELOCITY_MAGNITUDE, JOINT_VELOCITY_NAMES, Envelope, ErrorNames,
    derivative_thresholds, motion_figures,
)
from franka_sim.robot.checks.joint_table import SpeedLimitFloor, joint_limits
from franka_sim.robot.checks.measuring import SampleGrid
from franka_sim.robot.checks.violation import Violation

class _JointStream(CommandChecker):
    """What both joint interfaces share: the signed history, the floor and the explanation."""

    # The next start must stay within the floor's reach; the position check also needs it in
    # range (it judges the range itself, the velocity check leaves that to the law).
    _reach_in_range: bool

    def __init__(self, desc: ArmDescription, q_start, magnitude: float, order: int) -> None:
        if q_start is None:
            raise ValueError("a joint motion needs q_start")
        self._table = table = joint_limits(desc)
        self._grid = SampleGrid()
        self._q = table.signed(q_start)
        self._v, self._a = np.zeros(14), np.zeros(14)
        figures = motion_figures(desc)  # per joint, as signed 14-vectors
        self._acceleration = np.tile(figures.joint_acceleration, 2)
        self._jerk = np.tile(figures.joint_jerk, 2)
        self._v_slack, self._a_thr, self._j_thr = derivative_thresholds(
            Envelope(0.0, self._acceleration, self._jerk), magnitude, order)
        self._move_floor(self._q)

    def _move_floor(self, q_start: np.ndarray) -> None:
        floor = self._floor = SpeedLimitFloor(self._table, q_start)
        reach = floor.reach_in_range if self._reach_in_range else floor.reach
        self._proof_thresholds = np.concatenate(
            [reach, np.full(14, self._v_slack), self._a_thr, self._j_thr])

    def _proven_inside(self, q_next, v, a, j) -> bool:
        """The step is inside the limits, and q_next (the next step's start) within the floor's
        reach; False says nothing (NaN included), the law decides then."""
        stacked = np.concatenate((q_next, v - self._floor.limits, a, j))
        return all((stacked <= self._proof_thresholds).tolist())

    def _explain(self, out: list, names: ErrorNames, v, a, j, limits) -> None:
        for i in range(7):
            speed_limit = limits[i] if v[i] >= 0 else limits[i + 7]
            first_over(out, names, f"joint {i + 1}", "rad", (
                (abs(a[i]), self._a_thr[i], self._acceleration[i]),
                (abs(j[i]), self._j_thr[i], self._jerk[i]),
                (abs(v[i]), speed_limit + self._v_slack, speed_limit)))


class JointPositionChecker(_JointStream):
    """q_c: its range, and its first three derivatives."""

    _reach_in_range = True

    def __init__(self, desc: ArmDescription, q_start) -> None:
        super().__init__(desc, q_start, JOINT_POSITION_MAGNITUDE, 0)
        self._first = True

    def judge(self, command, n: int, out: list) -> None:
        first, self._first = self._first, False
        table = self._table
        s1, s2, s3 = self._grid.spacings(n)
        # q, v, a, j signed, and the proof (_proven_inside) in one call (kernels/).
        steps = np.empty(56)
        inside = joint_position_step(command["q_c"], self._q, self._v, self._a, s1, s2, s3,
                                     self._floor.limits, self._proof_thresholds, steps)
        q, v, a, j = steps.reshape(4, 14)
        if first and self._start_pose_invalid(q, out):
            v = a = np.zeros(14)  # the jump is reported as what it is; judge on from here
            self._report_range(q, out)
            self._move_floor(q)
        elif first or not inside:
            limits = table.speed_limits(self._q)  # the law where the step starts, as libfranka
            excess = np.maximum(v - limits - self._v_slack, q - table.ends)
            excess = np.maximum(excess, np.maximum(a - self._a_thr, j - self._j_thr))
            if not max(excess.tolist()) <= 0.0:
                self._report_range(q, out)
                self._explain(out, JOINT_POSITION_NAMES, v, a, j, limits)
            self._move_floor(q)
        self._q, self._v, self._a = q, v, a
        self._grid.advance(n)

    def _start_pose_invalid(self, q: np.ndarray, out: list) -> bool:
        offset = np.abs(q[:7] - self._q[:7])
        bad = np.flatnonzero(~(offset <= JOINT_START_TOLERANCE))
        out.extend(Violation(JOINT_START_ERROR, f"joint {i + 1}", float(offset[i]),
                             JOINT_START_TOLERANCE, quantity="start offset", unit="rad")
                   for i in bad)
        return len(bad) > 0

    def _report_range(self, q: np.ndarray, out: list) -> None:
        out.extend(Violation(JOINT_RANGE_ERROR, f"joint {i + 1}", float(q[i]), limit,
                             quantity="position", unit="rad")
                   for i, limit in self._table.ends_passed(q))


class JointVelocityChecker(_JointStream):
    """dq_c: the velocity law at the integrated position, and the next two derivatives.

    No range check of its own: the law allows 0 rad/s toward an end before the end is
    reached, so a stream that would leave the range breaks the velocity limit first.
    """

    _reach_in_range = False

    def __init__(self, desc: ArmDescription, q_start) -> None:
        super().__init__(desc, q_start, JOINT_VELOCITY_MAGNITUDE, 1)
        self._resumed = False

    def resume(self, q_d) -> None:
        """The robot integrates dq_c into its own q_d, which a gap carried on (or braked and
        held): the next command moves it one cycle from there, not from where the stream's
        last command would have taken it over the whole gap."""
        self._q = self._table.signed(q_d)
        self._move_floor(self._q)
        self._resumed = True

    def judge(self, command, n: int, out: list) -> None:
        dq = self._table.signed(command["dq_c"])
        s1, s2, _ = self._grid.spacings(n)
        a = (dq - self._v) / s1
        j = (a - self._a) / s2
        # The robot integrates dq_c into q_d; the law applies there.
        q_next = self._q + dq * (CYCLE_PERIOD if self._resumed else s1)
        self._resumed = False
        if not self._proven_inside(q_next, dq, a, j):
            limits = self._table.speed_limits(self._q)
            excess = np.maximum(dq - limits - self._v_slack,
                                np.maximum(a - self._a_thr, j - self._j_thr))
            if not max(excess.tolist()) <= 0.0:
                self._explain(out, JOINT_VELOCITY_NAMES, dq, a, j, limits)
            self._move_floor(q_next)
        self._q = q_next
        self._v, self._a = dq, a
        self._grid.advance(n)


class AsyncTargetChecker(CommandChecker):
    """An async motion's q_c is a goal for the robot's own generator (robot/async_target.py),
    not a stream: only its range is judged. A goal beyond an end is refused as a joint
    position command beyond it is; the generator never takes the arm past where the velocity
    law lets it move anyway. A finishing command's q_c is no goal (libfranka's stopControl
    sends zeros)."""

    def __init__(self, desc: ArmDescription) -> None:
        self._table = joint_limits(desc)

    def judge(self, command, cycles: int, out: list) -> None:
        if command["motion_generation_finished"]:
            return
        q_c = np.asarray(command["q_c"], dtype=float)
        signed = self._table.signed(q_c)
        if not max((signed - self._table.ends).tolist()) <= 0.0:
            out.extend(Violation(JOINT_RANGE_ERROR, f"joint {i + 1}", float(q_c[i]), limit,
                                 quantity="target", unit="rad")
                       for i, limit in self._table.ends_passed(signed))
