"""Mode pairs and fields pylibfranka cannot express, driven by a hand-written client:
torque control with a motion reference (kExternalController + a generator), and the elbow of
a Cartesian command (pylibfranka's CartesianPose carries none)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from franka_sim.protocol.errors import ERROR_NAMES
from franka_sim.testing import RawClient, running_sim
from support.clients import recover

MOVE, MOTION_STARTED, SUCCESS, REFLEX_ABORTED = 1, 1, 0, 8
EXTERNAL, JOINT_IMPEDANCE = 2, 0
JOINT_POSITION, CARTESIAN_POSITION = 0, 2


def _errors(state) -> list[str]:
    return [n for n, bit in zip(ERROR_NAMES, state["reflex_reason"]) if bit]


@pytest.fixture(scope="module")
def enforcing():
    with running_sim("--enforce-motion-limits", "--clock", "lockstep") as sim:
        yield sim


def test_torque_control_with_a_joint_position_reference(enforcing):
    """The client's torques drive the arm; its q_c is the reference the state reports as q_d."""
    c = RawClient(enforcing.host)
    try:
        assert c.move(EXTERNAL, JOINT_POSITION) == MOTION_STARTED
        assert (int(c.state["motion_generator_mode"]), int(c.state["controller_mode"])) == (1, 2)
        q0 = np.array(c.state["q_d"], dtype=float)
        tau_prev = np.zeros(7)
        for k in range(600):
            state = c.recv()
            q_c = q0.copy()
            q_c[6] += 0.1 * (1 - math.cos(math.pi * k / 599)) / 2
            q = np.array(state["q"], dtype=float)
            tau = 20.0 * (q_c - q) - 2.0 * np.array(state["dq"], dtype=float)  # the client's law
            tau = np.clip(tau, tau_prev - 0.9, tau_prev + 0.9) if k else np.zeros(7)  # ≤ 900 Nm/s
            c.send(q_c=q_c, tau_J_d=tau, motion_generation_finished=k == 599)
            if k == 300:
                np.testing.assert_allclose(state["q_d"][6], q0[6] + 0.05, atol=2e-3)
                np.testing.assert_allclose(state["tau_J_d"], tau_prev, atol=1e-4)
            tau_prev = tau
        assert c.reply()[::2] == (MOVE, SUCCESS), "\n".join(enforcing.lines)
        assert abs(c.recv()["q"][6] - (q0[6] + 0.1)) < 0.02  # the torques really moved it
    finally:
        c.close()


def _cartesian_stream(c, elbows, *, enforce_host):
    """Stream the start pose with the given elbow_c per cycle; return the Move's final status."""
    assert c.move(JOINT_IMPEDANCE, CARTESIAN_POSITION) == MOTION_STARTED
    pose = np.array(c.state["O_T_EE"], dtype=float)
    for elbow in elbows:
        state = c.recv()
        if int(state["robot_mode"]) != 2:
            break
        c.send(O_T_EE_c=pose, elbow_c=elbow, valid_elbow=True)
    return c.reply()[2], c.recv()


def test_elbow_sign_flip_mid_motion_is_refused(enforcing):
    c = RawClient(enforcing.host)
    try:
        q3, sign = (float(x) for x in c.state["elbow"])
        elbows = [(q3, sign)] * 20 + [(q3, -sign)] * 5
        status, state = _cartesian_stream(c, elbows, enforce_host=True)
    finally:
        c.close()
    assert status == REFLEX_ABORTED
    assert "cartesian_motion_generator_elbow_sign_inconsistent" in _errors(state)
    recover(enforcing.host)


def test_elbow_step_is_an_elbow_limit_violation(enforcing):
    c = RawClient(enforcing.host)
    try:
        q3, sign = (float(x) for x in c.state["elbow"])
        elbows = [(q3, sign)] * 20 + [(q3 + 0.05, sign)] * 5
        status, state = _cartesian_stream(c, elbows, enforce_host=True)
    finally:
        c.close()
    assert status == REFLEX_ABORTED
    assert "cartesian_motion_generator_elbow_limit_violation" in _errors(state)
    recover(enforcing.host)


def test_first_elbow_away_from_the_robot_is_an_invalid_start(enforcing):
    c = RawClient(enforcing.host)
    try:
        q3, sign = (float(x) for x in c.state["elbow"])
        status, state = _cartesian_stream(c, [(q3 + 0.2, sign)] * 5, enforce_host=True)
    finally:
        c.close()
    assert status == REFLEX_ABORTED
    assert "cartesian_motion_generator_start_elbow_invalid" in _errors(state)
    recover(enforcing.host)


def test_first_elbow_with_the_other_sign_is_a_start_elbow_sign_inconsistency(enforcing):
    c = RawClient(enforcing.host)
    try:
        q3, sign = (float(x) for x in c.state["elbow"])
        status, state = _cartesian_stream(c, [(q3, -sign)] * 5, enforce_host=True)
    finally:
        c.close()
    assert status == REFLEX_ABORTED
    assert "start_elbow_sign_inconsistent" in _errors(state)
    recover(enforcing.host)
