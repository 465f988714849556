"""Through pylibfranka: the EE moved down onto the table at 3 cm/s meets a force that builds up
over tens of states, so the client watches it rise before the reflex, and the collision
threshold it set decides when the reflex comes: 5 N stops the arm earlier, at less force,
than 20 N."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from support.clients import connect, move_to
from franka_sim.testing import running_sim

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import pick_and_place as pp  # noqa: E402  (its offline IK)

PAD_BOTTOM = 0.0175  # m under the TCP: where the fingers first touch the table
SPOT = (0.35, 0.2)  # on the table, clear of the cube
SPEED = 0.03  # m/s down
RAMP = 0.05  # s to reach it


@pytest.fixture(scope="module")
def robot():
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        yield robot
        del robot


def _descend(robot) -> list[tuple[float, float, float]]:
    """Down at SPEED until the robot aborts the motion: (time, O_F_ext_hat_K[2],
    cartesian_contact[2]) of every state the motion showed."""
    control = robot.start_cartesian_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    seen, t = [], 0.0
    with pytest.raises(pylibfranka.ControlException, match="cartesian_reflex"):
        while t < 2.0:
            state, period = control.readOnce()
            t += period.to_sec()
            seen.append((t, state.O_F_ext_hat_K[2], state.cartesian_contact[2]))
            v = -SPEED * 0.5 * (1 - math.cos(math.pi * min(t / RAMP, 1.0)))
            control.writeOnce(pylibfranka.CartesianVelocities([0.0, 0.0, v, 0.0, 0.0, 0.0]))
    del control
    return seen


def _press_until_reflex(robot, threshold: float):
    """From 5 mm over the touching height, down onto the table with the Cartesian collision
    threshold at `threshold` (contact from 2 N); the states seen, and the force at the reflex."""
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [2.0] * 6, [threshold] * 6)
    move_to(robot, pp.solve_ik([*SPOT, PAD_BOTTOM + 0.005], pp.READY), seconds=1.0)
    seen = _descend(robot)
    reflex = robot.read_once()
    assert "cartesian_reflex" in str(reflex.last_motion_errors)
    robot.automatic_error_recovery()
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    move_to(robot, pp.READY, seconds=1.0)
    return seen, reflex.O_F_ext_hat_K[2]


def test_the_force_builds_up_before_the_reflex_and_the_threshold_decides_it(robot):
    runs = {threshold: _press_until_reflex(robot, threshold) for threshold in (5.0, 20.0)}
    for threshold, (seen, _) in runs.items():
        pressing = [(t, f, c) for t, f, c in seen if f < -0.1]  # visibly pressing
        forces = [f for _, f, _ in pressing]
        assert len(forces) >= 10, (threshold, forces)
        assert all(np.diff(forces) < 0.0), forces  # rising, state after state
        assert forces[-1] > -threshold  # all of them under the threshold
        assert any(c == 1.0 for _, _, c in pressing)  # the contact flag shows it too
    (low, f_low), (high, f_high) = runs[5.0], runs[20.0]
    assert low[-1][0] < high[-1][0]  # 5 N stops the arm earlier ...
    assert abs(low[-1][1]) < abs(high[-1][1]) and abs(f_low) < abs(f_high)  # ... at less force
