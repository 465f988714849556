"""In lockstep, a change the control API makes plays out with no client, as a client's request
does: the frozen idle world is stepped until it is at rest again."""

from __future__ import annotations

import numpy as np
import pytest

from engines.engine_params import ENGINES, engine_server
from franka_sim.control import Control


@pytest.mark.parametrize("engine", ENGINES)
def test_a_placed_body_falls_and_a_pushed_arm_comes_back_without_a_client(engine):
    sim = engine_server(engine)
    try:
        control = Control(sim.host, timeout=300.0)  # (Genesis, niced, settles in its time)
        control.set_pose("cube", [0.45, 0.0, 0.3])
        assert control.pose("cube")["position"][2] < 0.03  # it fell onto the table at once
        before = control.state()
        control.push("link7", force=[0, 0, -30], duration=0.3)
        after = control.state()
    finally:
        sim.stop()
    assert after["cycle"] - before["cycle"] >= 300  # the push's cycles ran
    np.testing.assert_array_equal(after["q"], before["q"])  # and the hold took the arm back
