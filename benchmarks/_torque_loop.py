"""A pylibfranka torque loop that records what the long-run benchmarks judge (soak.py, storm.py).

Not a benchmark itself. Zero torques on the robot's gravity compensation: the arm holds still
and every cycle's exchange is the measure.
"""

from __future__ import annotations

import time

import numpy as np
import pylibfranka


def torque_loop(robot: pylibfranka.Robot, seconds: float) -> dict:
    """Run a torque motion for `seconds` of wall time. Returns the success rates the robot
    reported and the wall intervals between states, each with its wall time (perf_counter)."""
    control = robot.start_torque_control()
    control.readOnce()
    rates, intervals, stamps = [], [], []
    start = last = time.perf_counter()
    while True:
        state, _ = control.readOnce()
        now = time.perf_counter()
        rates.append(state.control_command_success_rate)
        intervals.append(now - last)
        stamps.append(now)
        last = now
        command = pylibfranka.Torques([0.0] * 7)
        command.motion_finished = now - start >= seconds
        control.writeOnce(command)
        if command.motion_finished:
            break
    return {"rates": np.array(rates), "intervals": np.array(intervals),
            "stamps": np.array(stamps)}


def percentiles_ms(intervals: np.ndarray) -> str:
    """p50 / p99 / p99.9 / max of intervals (s), in ms."""
    p50, p99, p999 = np.percentile(intervals, [50, 99, 99.9]) * 1000
    return f"p50 {p50:.3f}  p99 {p99:.3f}  p99.9 {p999:.3f}  max {intervals.max() * 1000:.2f} ms"
