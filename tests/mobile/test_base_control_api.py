"""The mobile base's control API, through HTTP: the rows of the table of operations whose kinds
include the base are served (its faults are its own UDP path's, robot index len(arms)); every
other row answers 404 with a JSON reason naming what the base serves, and one log line."""

from __future__ import annotations

import http.client
import json
import time

import pytest

from franka_sim.control import Control, NotFound
from franka_sim.control.table import OPERATIONS, Kind, served_by
from franka_sim.testing import ServerProcess, fresh_loopback_address

ABSENT = [op for op in OPERATIONS if Kind.BASE not in op.kinds]
BODIES = {"reset": {}, "set_pose": {"position": [0, 0, 1]}, "start_recording": {"path": "x"},
          "push": {"body": "hand", "force": [1, 0, 0]}}  # valid for an arm: still 404 here


@pytest.fixture(scope="module")
def duo():
    base, left, right = (fresh_loopback_address() for _ in range(3))
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}", "--arm",
                           f"right={right}", "--mobile-base", base,
                           "--clock", "lockstep").wait_ready()
    try:
        yield server, base, left, right
    finally:
        server.stop()


def request(host: str, method: str, path: str, body=None) -> tuple[int, dict]:
    connection = http.client.HTTPConnection(host, 1340, timeout=10)
    try:
        connection.request(method, path, None if body is None else json.dumps(body).encode())
        response = connection.getresponse()
        return response.status, json.loads(response.read())
    finally:
        connection.close()


@pytest.mark.parametrize("operation", ABSENT, ids=[op.name for op in ABSENT])
def test_a_row_the_base_lacks_is_404_with_the_reason(duo, operation):
    server, base, _, _ = duo
    path = operation.where(name="scene/cube")
    refusals = len(server.log_matching("refused (404)"))
    status, answer = request(base, operation.method, path, BODIES.get(operation.name))
    assert status == 404
    assert answer == {"error": f"the mobile base has no {operation.method} {operation.path} "
                               "(its control API serves /health, /state, /faults)"}
    end = time.monotonic() + 10
    while len(server.log_matching("refused (404)")) == refusals:
        assert time.monotonic() < end, "no log line for the refusal"
        time.sleep(0.005)
    logged = server.log_matching("refused (404)")[refusals:]
    assert len(logged) == 1 and f"{operation.method} {path} refused (404)" in logged[0]


def test_the_client_raises_not_found_for_what_the_base_lacks(duo):
    control = Control(duo[1])
    for call in (control.reset, control.bodies, lambda: control.pose("cube"),
                 lambda: control.push("hand", [1, 0, 0]), control.finish_recording):
        with pytest.raises(NotFound, match="the mobile base has no"):
            call()
    assert control.health()["mobile_base"] is True  # the rows it has
    assert set(control.state()["pose"]) == {"x", "y", "yaw"}
    assert {op.name for op in served_by(Kind.BASE)} == {
        "health", "state", "faults", "set_faults", "clear_faults"}


def test_the_bases_faults_are_its_own_path(duo):
    _, base, left, right = duo
    control = Control(base)
    try:
        report = control.set_faults(loss=0.1, dir="commands", seed=4)
        assert report["spec"] == "loss=0.1,dir=commands" and report["seed"] == 4
        assert control.faults()["spec"] == report["spec"]
        for arm in (left, right):  # robots 0 and 1: untouched by the base's (robot 2)
            assert Control(arm).faults()["spec"] is None
        Control(left).set_faults("delay=1ms")
        assert control.faults()["spec"] == "loss=0.1,dir=commands"
        status, answer = request(base, "POST", "/faults", {"loss": 2})
        assert status == 400 and "a probability is in [0, 1]" in answer["error"]
        assert control.clear_faults()["spec"] is None
        assert Control(left).faults()["spec"] == "delay=1ms"
    finally:
        control.clear_faults()
        Control(left).clear_faults()


def test_the_base_and_what_it_carries_are_not_pushed_or_placed(duo):
    """On an arm's control API: the base is moved by its own motion alone (a mocap body), and
    its first link with it; a push on them would change nothing."""
    from franka_sim.control import Conflict

    _, _, left, _ = duo
    control = Control(left)
    with pytest.raises(Conflict, match="'mobile_base' does not move under a push: only its "
                                       "own motion moves it"):
        control.push("mobile_base", [100.0, 0.0, 0.0])
    with pytest.raises(Conflict, match="'left/base' does not move under a push: it is carried "
                                       "by mobile_base"):
        control.push("left/base", [100.0, 0.0, 0.0])
    with pytest.raises(Conflict, match="'mobile_base' is not a free body: only its own motion"):
        control.set_pose("mobile_base", [1.0, 0.0, 0.0])
    assert control.push("left/link3", [1.0, 0.0, 0.0])["cycles"] == 100  # (a link moves)
