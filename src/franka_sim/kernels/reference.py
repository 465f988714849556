"""The cycle's fused vector loops in numpy: the specification the compiled module matches bit
for bit, and what runs where it was not built (kernels/__init__.py).

Each function is a run of small-array operations the cycle makes every step; on 7- and
14-vectors numpy spends its time dispatching (~0.3 µs a call here), so the compiled module does
each run in one call. The signed 14-vectors [x, −x] are JointLimitTable's (robot/checks/
joint_table.py).
"""

from __future__ import annotations

import math
import struct
from typing import Callable

import numpy as np

_TWICE = np.r_[0:7, 0:7]
_SIGNS = np.r_[np.ones(7), -np.ones(7)]
_TWICE_PAIR = np.r_[_TWICE, _TWICE + 7]  # [x, −x, y, −y] of [x, y]
_SIGNS_PAIR = np.tile(_SIGNS, 2)


def signed(x, out=None) -> np.ndarray:
    """[x, −x] for a (7,) vector (into `out` if given)."""
    return np.multiply(np.asarray(x, dtype=float)[_TWICE], _SIGNS, out=out)


def drive_follow(applied, ff, tau_ff, step: float, gcomp) -> None:
    """ff moves toward tau_ff by at most `step`; applied = ff + gcomp."""
    _follow(ff, tau_ff, step)
    np.add(ff, gcomp, out=applied)


def drive_impedance(applied, ff, tau_ff, step: float, gcomp, q_d, q, K, dq_d, dq, D) -> None:
    """ff moves toward tau_ff by at most `step`;
    applied = K·(q_d − q) + (dq_d − dq)·D + ff + gcomp, summed in that order."""
    _follow(ff, tau_ff, step)
    tmp = np.subtract(q_d, q)
    np.multiply(K, tmp, out=applied)
    np.subtract(dq_d, dq, out=tmp)
    tmp *= D
    applied += tmp
    applied += ff
    applied += gcomp


def _follow(ff, tau_ff, step: float) -> None:
    tmp = np.subtract(tau_ff, ff)
    np.minimum(tmp, step, out=tmp)
    np.maximum(tmp, -step, out=tmp)
    ff += tmp


def saturate_less(applied, tau_max, tau_min, friction) -> None:
    """applied clipped to [tau_min, tau_max], then less friction."""
    np.minimum(applied, tau_max, out=applied)
    np.maximum(applied, tau_min, out=applied)
    applied -= friction


def torque_inside(tau_J_d, last, out, effort, rate_threshold: float, dt: float) -> bool:
    """out = signed(tau_J_d); True if, signed, the rate from `last` over dt is within
    rate_threshold and the torque within `effort` (entries all ≤ 0 after subtracting)."""
    signed(tau_J_d, out)
    rate = (out - last) / dt
    return all((np.maximum(rate - rate_threshold, out - effort) <= 0.0).tolist())


def measured_inside(q, dq, offsets, thresholds) -> bool:
    """True if [signed(q), signed(dq)] − offsets ≤ thresholds everywhere (28 entries)."""
    stacked = np.concatenate((q, dq))[_TWICE_PAIR] * _SIGNS_PAIR
    return all((stacked - offsets <= thresholds).tolist())


def joint_position_step(q_c, q, v, a, s1: float, s2: float, s3: float, floor_limits,
                        thresholds, out) -> bool:
    """A q_c stream's next step, signed: out = [q', v', a', j'] (4 × 14) with q' = signed(q_c),
    v' = (q' − q)/s1, a' = (v' − v)/s2, j' = (a' − a)/s3. True if [q', v' − floor_limits, a', j']
    ≤ thresholds everywhere."""
    q_next = signed(q_c)
    v_next = (q_next - q) / s1
    a_next = (v_next - v) / s2
    j_next = (a_next - a) / s3
    np.concatenate((q_next, v_next, a_next, j_next), out=out)
    stacked = np.concatenate((q_next, v_next - floor_limits, a_next, j_next))
    return all((stacked <= thresholds).tolist())


def friction_argument(dq, phi3, half_phi2, out) -> None:
    """out = (dq + phi3)·half_phi2 (physics/friction.py takes its tanh)."""
    np.add(dq, phi3, out=out)
    out *= half_phi2


def friction_torque(tanh, at_rest, half_phi1, out) -> None:
    """out = (tanh − at_rest)·half_phi1."""
    np.subtract(tanh, at_rest, out=out)
    out *= half_phi1


def add_feed_forward(applied, M_ddq, bias, gravity) -> None:
    """applied = ((applied + M·ddq_d) + bias) − g: the reference's inverse dynamics, with
    MuJoCo's bias c + g and the g already applied."""
    applied += M_ddq
    applied += bias
    applied -= gravity


def impedance_torque(K, D, q_d, dq_d, q, dq, out) -> None:
    """out = K·(q_d − q) + D·(dq_d − dq); `out` float64 or float32 (a state field: rounded
    once, from the float64 result)."""
    out[:] = K * (q_d - q) + D * (dq_d - dq)


def joint_follow(q_c, q_d, dq_d, dt: float, out) -> None:
    """A joint position stream's next reference: out = [q_c, dq, (dq − dq_d)/dt] (3 × 7), with
    dq = (q_c − q_d)/dt."""
    q_next, dq, ddq = out.reshape(3, 7)
    q_next[:] = q_c
    np.divide(q_next - q_d, dt, out=dq)
    np.divide(dq - dq_d, dt, out=ddq)


def doubles_within(record, runs: tuple[tuple[int, int], ...], bound: float) -> bool:
    """Every little-endian double of `runs` ((byte offset, count) pairs) in the bytes of
    `record` is finite and within ±bound. One unpack; their sum is finite unless one of them
    is not or it overflowed (then each is looked at)."""
    unpacking = _RUNS.get(runs)
    if unpacking is None:
        unpacking = _RUNS[runs] = _runs_struct(runs)
    start, floats = unpacking
    values = floats.unpack_from(record, start)
    if math.isfinite(sum(values)):
        return max(values) <= bound and min(values) >= -bound
    return all(-bound <= v <= bound for v in values)


_RUNS: dict[tuple, tuple[int, struct.Struct]] = {}  # the unpacking of each runs seen


def _runs_struct(runs: tuple[tuple[int, int], ...]) -> tuple[int, struct.Struct]:
    """(offset, Struct) unpacking every double of `runs` at once, skipping what lies between."""
    start = position = runs[0][0]
    fmt = "<"
    for offset, count in runs:
        fmt += f"{offset - position}x{count}d" if offset > position else f"{count}d"
        position = offset + 8 * count
    return start, struct.Struct(fmt)


def narrow_into(targets: tuple, sources: tuple) -> None:
    """Each target (a state's float32 field, or float64) = its source (float64, of its shape),
    rounded as numpy casts; the tuples are of one length."""
    for target, source in zip(targets, sources):
        target[...] = source


def bind_readings(work, applied, armature, friction, stiffness, q, dq, timesteps, mat, pos,
                  sensordata, ddq, tau_J, theta, tau_J_theta, derivatives, work_q, work_dq,
                  flange_mat, flange_pos, work_sensors, gather) -> Callable:
    """A step's readings over one arm's arrays (physics/readings.py names them): returns
    readings(first, previous, out), which computes tau_J = applied − armature·ddq + friction,
    theta = tau_J/stiffness + q and the differences of [tau_J, theta] from `previous` over the
    timesteps (zero if `first`), copies q, dq, the flange and the sensors into the work array,
    and gathers it into `out` (None: the caller gathers, after changing the work array)."""
    gather = np.asarray(gather)

    def readings(first: bool, previous, out) -> None:
        np.multiply(armature, ddq, out=tau_J)
        np.subtract(applied, tau_J, out=tau_J)
        np.add(tau_J, friction, out=tau_J)
        np.divide(tau_J, stiffness, out=theta)
        np.add(theta, q, out=theta)
        if first:
            derivatives.fill(0.0)
        else:
            np.subtract(tau_J_theta, previous, out=derivatives)
            np.divide(derivatives, timesteps, out=derivatives)
        work_q[:] = q
        work_dq[:] = dq
        flange_mat[:] = mat
        flange_pos[:] = pos
        work_sensors[:] = sensordata
        if out is not None:
            np.take(work, gather, out=out[:gather.size])

    return readings
