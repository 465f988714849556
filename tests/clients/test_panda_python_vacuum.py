"""The vacuum gripper through a real client, unmodified: panda-python 1.1.1's VacuumGripper
(its bundled libfranka 0.9.2 speaks vacuum gripper protocol 1; tests/support/
panda_py_vacuum_program.py), against `--tool vacuum` in lockstep. It picks the cube with the
cup, carries it and drops it off where it lands on the table; and a part too heavy for the seal
in a fast turn (tests/data/heavy_part.xml, 1 kg) stays on through a slow turn and comes off in
a fast one. pylibfranka 0.21.3 has no binding of the vacuum gripper, franky none either."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from franka_sim.control import Control
from franka_sim.testing import running_sim
from support.client_venv import client_python

import pick_and_place as pp

PROGRAM = Path(__file__).resolve().parents[1] / "support" / "panda_py_vacuum_program.py"
HEAVY = Path(__file__).resolve().parents[1] / "data" / "heavy_part.xml"
AT = pp.solve_ik(pp.CUBE + [0, 0, 0.024], pp.READY)  # the lip 1 mm into the cube's top
ABOVE = pp.solve_ik(pp.CUBE + [0, 0, 0.175], AT)
PLACE = pp.PLACE + [0, 0, 0.03]  # the lip over the place: the cube's bottom 5 mm up
PLACE_AT = pp.solve_ik(PLACE, AT)
TURN = ABOVE + [0.8, 0, 0, 0, 0, 0, 0]  # joint 1 turns the part 0.8 rad about the base


@pytest.fixture(scope="module")
def python(tmp_path_factory) -> Path:
    return client_python("panda-python==1.1.1", tmp_path_factory.mktemp("panda-python"))


def _run(python, plan, *flags):
    """The program's answer, the cube's position after, and the simulator's log lines."""
    with running_sim("--clock", "lockstep", "--tool", "vacuum", *flags) as sim:
        done = subprocess.run([str(python), str(PROGRAM), sim.host, json.dumps(plan)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        cube = Control(sim.host).pose("cube")["position"]
        state = Control(sim.host).state()
        lost = sim.log_matching("came off")
    return json.loads(done.stdout.strip().splitlines()[-1]), np.array(cube), state, lost


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("vacuum") / "run.mcap"


@pytest.fixture(scope="module")
def placed(python, recording):
    return _run(python, {"above": ABOVE.tolist(), "at": AT.tolist(), "speed": 0.1,
                         "place_above": pp.solve_ik(PLACE + [0, 0, 0.15], PLACE_AT).tolist(),
                         "place_at": PLACE_AT.tolist()}, "--record", str(recording))


def test_it_connects_to_protocol_1_and_reads_an_idle_pump(placed):
    out, *_ = placed
    assert out["server_version"] == 1
    assert out["initial"] == {"in_control_range": False, "part_detached": False,
                              "part_present": False, "device_status": "kGreen",
                              "actual_power": 0, "vacuum": 0, "time": out["initial"]["time"]}


def test_it_vacuums_the_cube_and_carries_it_present(placed):
    out, *_ = placed
    assert out["vacuumed"] is True
    for leg in ("after_vacuum", "lifted", "carried"):
        state = out[leg]
        assert state["part_present"] and state["in_control_range"], leg
        assert state["vacuum"] == 750 and state["device_status"] == "kGreen", leg


def test_it_drops_the_cube_off_where_it_lands_on_the_table(placed):
    out, cube, state, lost = placed
    assert out["dropped"] is True
    assert out["after_drop"]["part_detached"] and not out["after_drop"]["part_present"]
    assert out["after_drop"]["vacuum"] == 0
    assert np.allclose(cube[:2], pp.PLACE[:2], atol=0.005)
    assert cube[2] == pytest.approx(0.025, abs=0.001)  # resting on the table
    assert state["vacuum_gripper"]["part_detached"] and state["vacuum_gripper"]["part"] is None
    assert lost == []  # it came off by the drop-off alone


def test_its_recording_holds_the_pump_and_replays_identical(placed, recording):
    with open(recording, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        counts = {summary.channels[c].topic: n
                  for c, n in summary.statistics.channel_message_counts.items()}
        requests = [json.loads(m.data) for _, c, m in reader.iter_messages(topics=["/fr3/tcp"])]
    assert counts["/fr3/vacuum_gripper_state"] > 100 and "/fr3/gripper_state" not in counts
    sent = [r["command"] for event in requests if event["service"] == "vacuum_gripper"
            for r in event["requests"]]
    assert sent == ["Connect", "Vacuum", "DropOff", "Stop"]
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(recording)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.startswith("identical"), \
        done.stdout + done.stderr


@pytest.mark.parametrize("speed, kept", [(0.1, True), (1.0, False)])
def test_a_part_too_heavy_for_a_fast_turn_comes_off_in_one(python, speed, kept):
    out, cube, state, lost = _run(python, {
        "above": ABOVE.tolist(), "at": AT.tolist(), "speed": 0.1, "thresholds": 100.0,
        "swing": TURN.tolist(), "swing_speed": speed}, "--scene", str(HEAVY))
    assert out["vacuumed"] and out["lifted"]["part_present"]
    assert out["swung"]["part_present"] is kept
    if kept:
        assert cube[2] > 0.15 and lost == []
    else:
        assert out["swung"]["device_status"] == "kYellow"  # the pump flat out on an open cup
        assert out["swung"]["actual_power"] == 100
        assert "peeled off" in lost[0] or "slid off" in lost[0]
        assert cube[2] == pytest.approx(0.025, abs=0.002)  # it fell onto the table


def test_vacuum_over_nothing_times_out_and_the_pump_stops(python):
    """In lockstep too: the world at rest when the timeout stops the pump still takes the step
    in which it stops (the idle pump's 0 %, not the last step's 100 %)."""
    out, *_ = _run(python, {"above": ABOVE.tolist(), "at": ABOVE.tolist(), "speed": 0.1})
    assert out["vacuumed"] is False
    assert out["after_vacuum"]["actual_power"] == 0 and out["after_vacuum"]["vacuum"] == 0
    assert not out["after_vacuum"]["part_present"]
