"""Motion-limit checks: judge a motion's command stream, and the measured arm, as the robot does.

`MotionLimitChecker` follows one Move. Each applied command is differentiated by backward
differences and held to the limits of `limits.py`; what trips comes back as `Violation`s named
with the FCI error the robot would latch. Only the active generator's signal is judged (a joint
motion carries a zero-filled O_T_EE_c that is not even a frame), plus tau_J_d under the external
controller. Enforcing (latching, reflex, the Move reply) is the caller's business.

Time is whatever the caller says: `cycles` is the interval the server observed since the
previously applied command. Each first difference belongs to the middle of its interval, so the
next order divides by the distance between those middles. On whole 1 ms cycles that is plain
backward Euler; after a burst of late datagrams it measures the rate the client really
commanded, where dividing every order by the last interval alone would overstate the first
regular cycle's acceleration (n+1)/2-fold. A client that resumes from its own stale waypoint
has commanded a real jump, and trips.

`check_measured` is the safety controller: the measured range and velocity, in every mode
(`MeasuredChecker` runs it cycle after cycle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.protocol.enums import MoveMotionGeneratorMode as Gen
from franka_sim.protocol.errors import error_index
from franka_sim.robot import limits as L
from franka_sim.robot.limits import (
    RAISED_ERRORS, ErrorNames, JointLimitTable, SampleGrid, SpeedLimitFloor,
    derivative_thresholds, joint_limits, rotation_rows, rotation_step,
)

__all__ = ["MeasuredChecker", "MotionLimitChecker", "RAISED_ERRORS", "Violation",
           "check_measured"]

_AT_REST = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # a 3-vector rate and its rate, both zero
_PER_SECOND = {"velocity": "/s", "acceleration": "/s²", "jerk": "/s³"}


@dataclass(frozen=True)
class Violation:
    """One limit a command (or the measured arm) broke, named as the robot names it."""

    name: str  # an ERROR_NAMES entry
    axis: str  # "joint 4", "translation", "rotation", "elbow", "frame"
    value: float  # the offending value
    limit: float  # the nominal limit it was held to (tolerances aside)
    aborts: bool = True  # False: the FCI only recommends this limit; log it, latch nothing
    quantity: str = ""  # "acceleration", "start offset", "sign", ...
    unit: str = ""

    def __post_init__(self) -> None:
        error_index(self.name)  # a typo must fail loudly, not set no bit

    def describe(self) -> str:
        """One line, e.g. "…_velocity_discontinuity: joint 4 acceleration 123.4 rad/s² > 10"."""
        relation = "≠" if self.quantity == "sign" else (">" if self.value > self.limit else "<")
        what = " ".join(part for part in (self.axis, self.quantity) if part)
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.name}: {what} {self.value:.6g}{unit} {relation} {self.limit:.6g}"


def _first_over(out: list, names: ErrorNames, axis: str, unit: str, checks) -> None:
    """Report the first derivative over its threshold; `checks` holds (value, threshold,
    nominal) for acceleration, jerk and velocity, in that order.

    A step trips all three at once. The lowest-order discontinuity is its cause, and a
    discontinuity wins over the velocity limit, which is for a signal smoothly too fast.
    """
    for quantity, name, (value, threshold, nominal) in zip(
            ("acceleration", "jerk", "velocity"), (names.acceleration, names.jerk, names.velocity),
            checks):
        if not value <= threshold:
            out.append(Violation(name, axis, float(value), float(nominal), quantity=quantity,
                                 unit=unit + _PER_SECOND[quantity]))
            return


class MotionLimitChecker:
    """Judges one motion's command stream; a fresh one per Move.

    q_start / O_T_EE_start (4×4, or 16 numbers column-major) / elbow_start are the start the
    robot holds (what the state showed as the motion began). Each signal's history starts at
    rest there, as the robot requires: the first command must equal it, and the stream must
    accelerate from zero. Only those the generator needs are required.
    """

    def __init__(self, desc: ArmDescription, generator: Gen, torque_controlled: bool, *,
                 q_start=None, O_T_EE_start=None, elbow_start=None) -> None:
        self.generator = Gen(generator)
        self.torque_controlled = bool(torque_controlled)
        self._table = table = joint_limits(desc)
        self._first = True
        self._checks = []
        self._grid = SampleGrid()
        if self.generator in (Gen.kJointPosition, Gen.kJointVelocity):
            if q_start is None:
                raise ValueError("a joint motion needs q_start")
            position = self.generator is Gen.kJointPosition
            self._q = table.signed(q_start)  # signed 14-vectors [x, −x], see JointLimitTable
            self._v, self._a = np.zeros(14), np.zeros(14)
            magnitude = L.JOINT_POSITION_MAGNITUDE if position else L.JOINT_VELOCITY_MAGNITUDE
            self._v_slack, self._a_thr, self._j_thr = derivative_thresholds(
                L.Envelope(0.0, L.JOINT_ACCELERATION, L.JOINT_JERK), magnitude, 1 - position)
            self._move_floor(self._q)
            self._checks.append(self._joint_position if position else self._joint_velocity)
        elif self.generator in (Gen.kCartesianPosition, Gen.kCartesianVelocity):
            pose = self.generator is Gen.kCartesianPosition
            magnitude = L.CARTESIAN_POSITION_MAGNITUDE if pose else L.TWIST_MAGNITUDE
            self._t_thr = derivative_thresholds(L.CARTESIAN_TRANSLATION, magnitude, 1 - pose)
            self._r_thr = derivative_thresholds(L.CARTESIAN_ROTATION, magnitude, 1 - pose)
            self._lin = self._ang = _AT_REST
            if pose:
                if O_T_EE_start is None:
                    raise ValueError("a Cartesian pose motion needs O_T_EE_start")
                T = np.asarray(O_T_EE_start, dtype=float)
                m = (T.ravel(order="F") if T.shape == (4, 4) else T.ravel()).tolist()
                self._R, self._p = rotation_rows(m), (m[12], m[13], m[14])
            self._checks.append(self._cartesian_pose if pose else self._cartesian_velocity)
            self._e_thr = derivative_thresholds(L.ELBOW, L.ELBOW_MAGNITUDE, 0)
            self._e_grid = SampleGrid()
            self._e_start = None if elbow_start is None else [float(x) for x in elbow_start[:2]]
            self._elbow = None if elbow_start is None else (self._e_start[0], 0.0, 0.0)
            self._e_sign = 0.0 if elbow_start is None else _sign(self._e_start[1])
            self._checks.append(self._elbow_check)
        if self.torque_controlled:
            self._tau = np.zeros(14)  # a torque motion starts from tau_d = 0
            self._effort = np.tile(table.effort, 2)
            self._rate_thr = L.TORQUE_RATE + L.echo_slack(L.TORQUE_MAGNITUDE, 1)
            self._checks.append(self._torque)

    def check(self, command, cycles: int) -> list[Violation]:
        """Judge one applied command, `cycles` (≥ 1) cycles after the previously applied one.

        Call it for applied commands only; a cycle without one (lost, or overtaken by a newer
        datagram) simply widens the next call's `cycles`.

        `command`: a decoded RobotCommand (or a mapping with its field names), finite — the
        core drops non-finite datagrams before applying them.
        """
        if cycles < 1:
            raise ValueError(f"cycles must be ≥ 1, got {cycles}")
        out: list[Violation] = []
        for check in self._checks:
            check(command, cycles, out)
        self._first = False
        return out

    # -- joint interfaces -----------------------------------------------------------------------
    # The joint checks first try to prove a step inside every limit against a SpeedLimitFloor
    # laid at the previous command (where the law applies): one comparison of the stacked
    # [next start, velocity − floor, acceleration, jerk] against their thresholds. Only when
    # that fails do they evaluate the law and explain; the floor then moves to the new start.
    # Either way the verdict is the law's own (see SpeedLimitFloor).
    def _move_floor(self, q_start: np.ndarray) -> None:
        floor = self._floor = SpeedLimitFloor(self._table, q_start)
        reach = floor.reach_in_range if self.generator is Gen.kJointPosition else floor.reach
        self._proof_thresholds = np.concatenate(
            [reach] + [np.full(14, x) for x in (self._v_slack, self._a_thr, self._j_thr)])

    def _proven_inside(self, q_next, v, a, j) -> bool:
        """The step is inside the limits, and q_next (the next step's start) within the floor's
        reach; False says nothing (NaN included), the law decides then."""
        stacked = np.concatenate((q_next, v - self._floor.limits, a, j))
        return all((stacked <= self._proof_thresholds).tolist())

    def _joint_position(self, command, n: int, out: list) -> None:
        table = self._table
        q = table.signed(command["q_c"])
        s1, s2, s3 = self._grid.spacings(n)
        v = (q - self._q) / s1
        a = (v - self._v) / s2
        j = (a - self._a) / s3
        if self._first and self._start_pose_invalid(q, out):
            v = a = np.zeros(14)  # the jump is reported as what it is; judge on from here
            self._report_range(q, out)
            self._move_floor(q)
        elif self._first or not self._proven_inside(q, v, a, j):
            limits = table.speed_limits(self._q)  # the law where the step starts, as libfranka
            excess = np.maximum(v - limits - self._v_slack, q - table.ends)
            excess = np.maximum(excess, np.maximum(a - self._a_thr, j - self._j_thr))
            if not max(excess.tolist()) <= 0.0:
                self._report_range(q, out)
                self._explain_joints(out, L.JOINT_POSITION_NAMES, v, a, j, limits)
            self._move_floor(q)
        self._q, self._v, self._a = q, v, a
        self._grid.advance(n)

    def _joint_velocity(self, command, n: int, out: list) -> None:
        # No range check of its own: the law allows 0 rad/s toward an end before the end is
        # reached, so a stream that would leave the range breaks the velocity limit first.
        dq = self._table.signed(command["dq_c"])
        s1, s2, _ = self._grid.spacings(n)
        a = (dq - self._v) / s1
        j = (a - self._a) / s2
        q_next = self._q + dq * s1  # the robot integrates dq_c into q_d; the law applies there
        if not self._proven_inside(q_next, dq, a, j):
            limits = self._table.speed_limits(self._q)
            excess = np.maximum(dq - limits - self._v_slack,
                                np.maximum(a - self._a_thr, j - self._j_thr))
            if not max(excess.tolist()) <= 0.0:
                self._explain_joints(out, L.JOINT_VELOCITY_NAMES, dq, a, j, limits)
            self._move_floor(q_next)
        self._q = q_next
        self._v, self._a = dq, a
        self._grid.advance(n)

    def _start_pose_invalid(self, q: np.ndarray, out: list) -> bool:
        offset = np.abs(q[:7] - self._q[:7])
        bad = np.flatnonzero(~(offset <= L.JOINT_START_TOLERANCE))
        out.extend(Violation(L.JOINT_START_ERROR, f"joint {i + 1}", float(offset[i]),
                             L.JOINT_START_TOLERANCE, quantity="start offset", unit="rad")
                   for i in bad)
        return len(bad) > 0

    def _report_range(self, q: np.ndarray, out: list) -> None:
        out.extend(Violation(L.JOINT_RANGE_ERROR, f"joint {i + 1}", float(q[i]), limit,
                             quantity="position", unit="rad")
                   for i, limit in self._table.ends_passed(q))

    def _explain_joints(self, out: list, names: ErrorNames, v, a, j, limits) -> None:
        for i in range(7):
            speed_limit = limits[i] if v[i] >= 0 else limits[i + 7]
            _first_over(out, names, f"joint {i + 1}", "rad", (
                (abs(a[i]), self._a_thr, L.JOINT_ACCELERATION),
                (abs(j[i]), self._j_thr, L.JOINT_JERK),
                (abs(v[i]), speed_limit + self._v_slack, speed_limit)))

    # -- Cartesian interfaces -------------------------------------------------------------------
    def _cartesian_pose(self, command, n: int, out: list) -> None:
        m = np.asarray(command["O_T_EE_c"], dtype=float).tolist()
        defect = L.frame_defect(m)
        if defect is not None:
            value, limit, quantity = defect
            out.append(Violation(L.INVALID_FRAME_ERROR, "frame", value, limit, quantity=quantity))
            self._grid.pending += n  # the next valid pose is judged against the last valid one
            return
        n += self._grid.pending
        s1, s2, s3 = self._grid.spacings(n)
        R, p, P = rotation_rows(m), (m[12], m[13], m[14]), self._p
        lin = ((p[0] - P[0]) / s1, (p[1] - P[1]) / s1, (p[2] - P[2]) / s1)
        angle, axis = rotation_step(self._R, R)
        if self._first and self._cartesian_start_invalid(math.hypot(*lin) * s1, angle, out):
            self._lin = self._ang = _AT_REST
        else:
            self._lin = _rates(out, L.CARTESIAN_POSE_NAMES, "translation", "m", lin, self._lin,
                               s2, s3, self._t_thr, L.CARTESIAN_TRANSLATION)
            omega = (axis[0] * angle / s1, axis[1] * angle / s1, axis[2] * angle / s1)
            self._ang = _rates(out, L.CARTESIAN_POSE_NAMES, "rotation", "rad", omega, self._ang,
                               s2, s3, self._r_thr, L.CARTESIAN_ROTATION, speed=angle / s1)
        self._R, self._p = R, p
        self._grid.advance(n)

    def _cartesian_velocity(self, command, n: int, out: list) -> None:
        twist = np.asarray(command["O_dP_EE_c"], dtype=float).tolist()
        s1, s2, _ = self._grid.spacings(n)
        names = L.CARTESIAN_VELOCITY_NAMES
        self._lin = _rates(out, names, "translation", "m", twist[:3], self._lin, s1, s2,
                           self._t_thr, L.CARTESIAN_TRANSLATION)
        self._ang = _rates(out, names, "rotation", "rad", twist[3:], self._ang, s1, s2,
                           self._r_thr, L.CARTESIAN_ROTATION)
        self._grid.advance(n)

    def _cartesian_start_invalid(self, offset: float, angle: float, out: list) -> bool:
        before = len(out)
        for axis, value, tolerance, unit in (
                ("translation", offset, L.CARTESIAN_START_TRANSLATION_TOLERANCE, "m"),
                ("rotation", angle, L.CARTESIAN_START_ROTATION_TOLERANCE, "rad")):
            if not value <= tolerance:
                out.append(Violation(L.CARTESIAN_START_ERROR, axis, value, tolerance,
                                     quantity="start offset", unit=unit))
        return len(out) > before

    def _elbow_check(self, command, n: int, out: list) -> None:
        grid = self._e_grid
        if not command["valid_elbow"]:  # no elbow commanded: elbow_c is zero fill, not a signal
            grid.pending += n
            return
        position, flag = np.asarray(command["elbow_c"], dtype=float).tolist()[:2]
        start = self._e_start if self._first else None
        if start is not None and not abs(position - start[0]) <= L.ELBOW_START_TOLERANCE:
            out.append(Violation(L.ELBOW_START_ERROR, "elbow", abs(position - start[0]),
                                 L.ELBOW_START_TOLERANCE, quantity="start offset", unit="rad"))
            self._elbow = None  # reported; judge on from here
        sign = _sign(flag)
        if sign and self._e_sign and sign != self._e_sign:
            name = L.ELBOW_START_SIGN_ERROR if start is not None else L.ELBOW_SIGN_ERROR
            out.append(Violation(name, "elbow", sign, self._e_sign, quantity="sign"))
        self._e_sign = sign or self._e_sign
        n += grid.pending
        if self._elbow is None:  # nothing to difference against: this sample anchors the history
            self._elbow = (position, 0.0, 0.0)
        else:
            s1, s2, s3 = grid.spacings(n)
            e0, v0, a0 = self._elbow
            v = (position - e0) / s1
            a = (v - v0) / s2
            j = (a - a0) / s3
            thr, env = self._e_thr, L.ELBOW
            if not (abs(v) <= thr[0] and abs(a) <= thr[1] and abs(j) <= thr[2]):
                _first_over(out, L.ELBOW_NAMES, "elbow", "rad", (
                    (abs(a), thr[1], env.acceleration), (abs(j), thr[2], env.jerk),
                    (abs(v), thr[0], env.velocity)))
            self._elbow = (position, v, a)
        grid.advance(n)

    # -- torque ---------------------------------------------------------------------------------
    def _torque(self, command, n: int, out: list) -> None:
        tau = self._table.signed(command["tau_J_d"])
        rate = (tau - self._tau) / (n * L.DT)
        if not max(np.maximum(rate - self._rate_thr, tau - self._effort).tolist()) <= 0.0:
            for i in range(7):
                if not abs(rate[i]) <= self._rate_thr:
                    out.append(Violation(L.TORQUE_RATE_ERROR, f"joint {i + 1}", float(abs(rate[i])),
                                         L.TORQUE_RATE, quantity="torque rate", unit="Nm/s"))
                if not abs(tau[i]) <= self._effort[i]:
                    out.append(Violation(L.TORQUE_RANGE_ERROR, f"joint {i + 1}", float(abs(tau[i])),
                                         float(self._effort[i]), aborts=False, quantity="torque",
                                         unit="Nm"))
        self._tau = tau


def _rates(out, names, axis, unit, vel, previous, s_a, s_j, thresholds, envelope, speed=None):
    """Judge a 3-vector rate and its next two differences by their norms; the new history."""
    v0, a0 = previous
    acc = ((vel[0] - v0[0]) / s_a, (vel[1] - v0[1]) / s_a, (vel[2] - v0[2]) / s_a)
    jerk = ((acc[0] - a0[0]) / s_j, (acc[1] - a0[1]) / s_j, (acc[2] - a0[2]) / s_j)
    speed = math.hypot(*vel) if speed is None else speed
    a_norm, j_norm = math.hypot(*acc), math.hypot(*jerk)
    if not (speed <= thresholds[0] and a_norm <= thresholds[1] and j_norm <= thresholds[2]):
        _first_over(out, names, axis, unit, (
            (a_norm, thresholds[1], envelope.acceleration), (j_norm, thresholds[2], envelope.jerk),
            (speed, thresholds[0], envelope.velocity)))
    return tuple(vel), acc


def _sign(x: float) -> float:
    return math.copysign(1.0, x) if x else 0.0


def check_measured(desc: ArmDescription, q, dq) -> list[Violation]:
    """The safety controller: the measured arm against the URDF range and velocity law, any mode.

    Measured velocity gets MEASURED_VELOCITY_TOLERANCE of slack (sensor noise; see limits.py).
    """
    table = joint_limits(desc)
    return _measured_violations(table, table.signed(q), table.signed(dq))


class MeasuredChecker:
    """check_measured for one motion, cycle after cycle: the law is evaluated only when a
    SpeedLimitFloor near the arm cannot prove it inside (the verdict is the same)."""

    def __init__(self, desc: ArmDescription) -> None:
        self._table = joint_limits(desc)
        self._proof: tuple | None = None  # (offsets, thresholds) of the floor, see check

    def check(self, q, dq) -> list[Violation]:
        table, proof = self._table, self._proof
        signed = table.signed_stack(q, dq)
        # In range and within the floor's reach (q − 0 ≤ reach), and no faster than the floor
        # allows (dq − floor ≤ tolerance): nothing to report.
        if proof is not None and all((signed - proof[0] <= proof[1]).tolist()):
            return []
        q, dq = signed[:14], signed[14:]
        floor = SpeedLimitFloor(table, q)
        self._proof = (np.concatenate((np.zeros(14), floor.limits)),
                       np.concatenate((floor.reach_in_range,
                                       np.full(14, L.MEASURED_VELOCITY_TOLERANCE))))
        return _measured_violations(table, q, dq)


def _measured_violations(table: JointLimitTable, q: np.ndarray,
                         dq: np.ndarray) -> list[Violation]:
    """check_measured on signed q and dq."""
    tolerance = L.MEASURED_VELOCITY_TOLERANCE
    excess = q - table.ends
    moving = max(dq.tolist()) > tolerance  # slower never trips: the law is never below 0
    if moving:
        limits = table.speed_limits(q)
        excess = np.maximum(excess, dq - limits - tolerance)
    if max(excess.tolist()) <= 0.0:
        return []
    out = [Violation(L.MEASURED_RANGE_ERROR, f"joint {i + 1}", float(q[i]), limit,
                     quantity="measured position", unit="rad") for i, limit in table.ends_passed(q)]
    if moving:
        out.extend(Violation(L.MEASURED_VELOCITY_ERROR, f"joint {e % 7 + 1}", float(abs(dq[e])),
                             float(limits[e]), quantity="measured velocity", unit="rad/s")
                   for e in np.flatnonzero(~(dq <= limits + tolerance)))
    return out
