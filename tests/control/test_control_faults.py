"""POST, GET and DELETE /faults: faults set, counted and cleared at runtime on one arm's UDP
path; bad specs answered 400 with the reason, nothing changed."""

from __future__ import annotations

import http.client
import json

import pylibfranka
import pytest

from franka_sim.control import BadRequest, Control
from support.clients import connect

NOTHING = {"seen": 0, "dropped": 0, "delayed": 0, "reordered": 0, "held": 0}


@pytest.fixture
def faults(control: Control):
    """The control client, with no faults before and after the test."""
    control.clear_faults()
    yield control
    control.clear_faults()


def _zero_torques(host: str, cycles: int = 300) -> None:
    robot = connect(host)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    loop = robot.start_torque_control()
    for k in range(cycles):
        loop.readOnce()
        command = pylibfranka.Torques([0.0] * 7)
        command.motion_finished = k == cycles - 1
        loop.writeOnce(command)
    del loop, robot


def test_faults_set_at_runtime_are_counted_and_cleared(faults: Control, served):
    report = faults.faults()
    assert report["spec"] is None and report["seed"] == 0
    assert report["states"] == report["commands"] == NOTHING
    report = faults.set_faults(loss=0.2, delay="0ms", dir="commands", seed=11)
    assert report["spec"] == "loss=0.2,dir=commands" and report["seed"] == 11
    assert report["fields"]["loss"] == 0.2 and report["fields"]["dir"] == "commands"
    _zero_torques(served.host)
    report = faults.faults()
    assert report["states"]["seen"] > 300 and report["states"]["dropped"] == 0
    assert report["commands"]["seen"] >= 300
    assert 0.1 * 300 < report["commands"]["dropped"] < 0.3 * 300
    cleared = faults.clear_faults()
    assert cleared["spec"] is None
    assert cleared["commands"]["dropped"] == report["commands"]["dropped"]  # what they did
    _zero_torques(served.host)
    assert faults.faults()["commands"]["dropped"] == report["commands"]["dropped"]
    assert faults.state()["robot_mode"] == "Idle"
    # A reset world counts from zero; the faults set go on.
    faults.set_faults(loss=0.2, dir="commands", seed=11)
    _zero_torques(served.host, 100)
    assert faults.faults()["commands"]["dropped"] > 0
    faults.reset()
    report = faults.faults()
    assert report["spec"] == "loss=0.2,dir=commands"
    assert report["states"] == report["commands"] == NOTHING


@pytest.mark.parametrize("given", [{"loss": 0}, {"delay": 0, "dir": "states"}, {"burst": []},
                                   {"spec": "loss=0,reorder=0"}])
def test_faults_that_inject_nothing_are_none(faults: Control, given):
    """A sweep's baseline (loss=0) replaces what was set with nothing, reported as nothing."""
    faults.set_faults(loss=0.5)
    report = faults.set_faults(**given)
    assert report["spec"] is None and report["fields"] is None and report["origin"] is None


def test_a_spec_string_replaces_what_was_set(faults: Control):
    faults.set_faults(loss=0.5)
    report = faults.set_faults("burst=25@3s,burst=5@1s,reorder=0.01")
    assert report["spec"] == "burst=5@1s,burst=25@3s,reorder=0.01"
    assert report["fields"]["burst"] == ["5@1s", "25@3s"] and report["fields"]["loss"] == 0.0
    assert faults.faults()["spec"] == report["spec"]


@pytest.mark.parametrize("body, reason", [
    (b"", "expected a JSON object"),
    (b"{}", "no fault given"),
    (b'{"lost": 0.1}', "unknown field(s) 'lost'"),
    (b'{"loss": 2}', "loss=2: a probability is in [0, 1]"),
    (b'{"loss": "often"}', "not a number"),
    (b'{"delay": "2 hours"}', "not a duration"),
    (b'{"burst": "25"}', "expected N@T"),
    (b'{"burst": [25]}', "expected N@T"),
    (b'{"burst": "25@1e400s"}', "the start is a whole ms"),  # (its ms overflow to infinity)
    (b'{"spec": "burst=25@1e308s"}', "the start is a whole ms"),
    ('{"burst": "\u00b2@3s"}'.encode(), "expected N@T"),  # a digit int() does not read
    (b'{"dir": "up"}', "expected both, states, commands"),
    (b'{"spec": "loss=0.1", "loss": 0.1}', "either spec or the fields"),
    (b'{"spec": "los=0.1"}', "unknown fault 'los'"),
    (b'{"spec": 3}', "a spec is a string"),
    (b'{"loss": 0.1, "seed": -1}', "seed must be an integer"),
    (b'{"loss": 0.1, "seed": 1.5}', "seed must be an integer"),
])
def test_a_bad_spec_is_answered_400_and_changes_nothing(faults: Control, served, body, reason):
    faults.set_faults(loss=0.01)
    connection = http.client.HTTPConnection(served.host, 1340, timeout=5)
    connection.request("POST", "/faults", body, {"Content-Type": "application/json"})
    response = connection.getresponse()
    answer = json.loads(response.read())
    connection.close()
    assert response.status == 400 and reason in answer["error"], answer
    assert faults.faults()["spec"] == "loss=0.01"


def test_the_client_raises_bad_request(faults: Control):
    with pytest.raises(BadRequest, match="a probability"):
        faults.set_faults(loss=1.5)


def test_embedded_the_faults_are_async_methods_with_the_same_errors():
    import asyncio

    from franka_sim import FrankaSim
    from franka_sim.testing import fresh_loopback_address

    async def app():
        async with FrankaSim(host=fresh_loopback_address(), control_port=0,
                             inject="loss=0.1", seed=5) as sim:
            first = await sim.faults()
            with pytest.raises(BadRequest, match="unknown fault"):
                await sim.set_faults({"spec": "lost=0.1"})
            with pytest.raises(BadRequest, match="a spec .* or its fields as a dict"):
                await sim.set_faults(["loss=0.1"])
            assert (await sim.set_faults("delay=2ms"))["spec"] == "delay=2ms"  # a spec alone
            # as the HTTP client takes them: a spec and a seed, or the fields as keywords
            assert (await sim.set_faults("delay=2ms", seed=7))["seed"] == 7
            assert (await sim.set_faults(loss=0.01, dir="commands"))["spec"] == \
                "loss=0.01,dir=commands"
            with pytest.raises(TypeError, match="'lossy'"):
                await sim.set_faults(lossy=0.01)
            second = await sim.set_faults({"burst": "10@60s"})
            cleared = await sim.clear_faults()
            return first, second, cleared, sim.driver.faults, sim.udp.faults

    first, second, cleared, driver_faults, endpoint_faults = asyncio.run(app())
    assert first["spec"] == "loss=0.1" and first["seed"] == 5
    assert second["spec"] == "burst=10@60s"
    assert cleared["spec"] is None
    assert driver_faults is None and endpoint_faults is None  # the plain path again
