"""Through pylibfranka: the EE moved down onto the table at 3 cm/s meets a force that builds up
over tens of states, so the client watches it rise before the reflex, and the collision
threshold it set decides when the reflex comes: 5 N stops the arm earlier, at less force,
than 20 N."""

from __future__ import annotations

import numpy as np
import pytest

from support.clients import connect, press_until_reflex
from franka_sim.testing import running_sim


@pytest.fixture(scope="module")
def robot():
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        yield robot
        del robot


def test_the_force_builds_up_before_the_reflex_and_the_threshold_decides_it(robot):
    runs = {threshold: press_until_reflex(robot, threshold) for threshold in (5.0, 20.0)}
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
