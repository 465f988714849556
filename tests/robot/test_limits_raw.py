"""The safety layer against hand-written command streams libfranka cannot produce: bursts of
late datagrams, a client resuming from its own stale waypoint, invalid frames, NaNs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from franka_sim.protocol.errors import ERROR_NAMES
from franka_sim.testing import RawClient, running_sim
from support.clients import recover

MOVE, MOTION_STARTED, SUCCESS, REFLEX_ABORTED = 1, 1, 0, 8


@pytest.fixture(scope="module")
def enforcing():
    with running_sim("--enforce-motion-limits", "--clock", "lockstep") as sim:
        yield sim


def _trajectory(q0: np.ndarray, n: int) -> np.ndarray:
    """Joint 4 swings out 0.25 rad and back in 2 s, ending at rest (peak 0.79 rad/s)."""
    q = q0.copy()
    q[3] += 0.25 * (1 - math.cos(2 * math.pi * n / 2000))
    return q


def _errors(state) -> list[str]:
    return [name for name, bit in zip(ERROR_NAMES, state["errors"]) if bit]


def _run(host: str, stall_at: int, stall: int, stale_resume: bool, cycles: int = 2000):
    """Follow the trajectory; at `stall_at`, go quiet for `stall` cycles, then either send the
    missed commands as one late burst (a conforming client) or resume from the stale waypoint."""
    c = RawClient(host)
    try:
        assert c.move(0, 0) == MOTION_STARTED
        q0 = np.array(c.state["q_d"], dtype=float)
        id0 = int(c.state["message_id"])
        n_sent, lag = 0, 0
        while n_sent < cycles:
            state = c.recv()
            if int(state["robot_mode"]) != 2:
                return c.reply(), _errors(state)
            mid = int(state["message_id"])
            n = mid - id0
            if n_sent == stall_at:
                for _ in range(stall):
                    c.recv()  # states arrive; the client says nothing
                if stale_resume:
                    lag = stall + 1  # its own clock stood still: it continues where it left off
                else:
                    for k in range(stall + 1):  # the missed answers arrive back to back, late
                        c.send(message_id=mid + k, q_c=_trajectory(q0, n + k))
                    n_sent += stall + 1
                    continue
            c.send(q_c=_trajectory(q0, n - lag), motion_generation_finished=n_sent == cycles - 1)
            n_sent += 1
        while int(c.recv()["robot_mode"]) == 2:
            c.send(q_c=_trajectory(q0, cycles), motion_generation_finished=True)
        return c.reply(), _errors(c.state)
    finally:
        c.close()


@pytest.mark.parametrize("stall", [1, 2, 5, 11])
def test_a_burst_of_late_datagrams_resumes_clean(enforcing, stall):
    (command, _, status), errors = _run(enforcing.host, 500, stall, stale_resume=False)
    assert (command, status, errors) == (MOVE, SUCCESS, [])


def test_resuming_from_a_stale_waypoint_after_a_gap_is_a_discontinuity(enforcing):
    (command, _, status), errors = _run(enforcing.host, 500, 15, stale_resume=True)
    assert (command, status) == (MOVE, REFLEX_ABORTED)
    assert "joint_motion_generator_velocity_discontinuity" in errors
    recover(enforcing.host)


def test_an_invalid_frame_is_refused_by_name(enforcing):
    c = RawClient(enforcing.host)
    try:
        assert c.move(0, 2) == MOTION_STARTED
        c.recv()  # the state after the modes flipped: lockstep waits for its answer
        T = np.reshape(np.array(c.state["O_T_EE"], dtype=float), (4, 4), order="F")
        T[:3, :3] *= 1.1  # scaled: not a rotation
        c.send(O_T_EE_c=T.ravel(order="F"))
        assert c.reply()[2] == REFLEX_ABORTED
        assert "cartesian_position_motion_generator_invalid_frame" in _errors(c.recv())
    finally:
        c.close()
    recover(enforcing.host)


@pytest.mark.parametrize("flags", [(), ("--enforce-motion-limits",)])
def test_non_finite_commands_never_reach_the_physics(flags):
    with running_sim(*flags) as sim:
        c = RawClient(sim.host)
        try:
            assert c.move(0, 0) == MOTION_STARTED
            q = np.array(c.state["q_d"], dtype=float)
            bad = q.copy()
            bad[2] = np.nan
            for _ in range(20):
                c.recv()
                c.send(q_c=bad)
            state = c.recv()
            assert np.all(np.isfinite(state["q_d"])) and np.all(np.isfinite(state["q"]))
            assert int(state["robot_mode"]) == 2 and not _errors(state)
            assert sim.wait_for_log("dropped: non-finite q_c")
        finally:
            c.close()
