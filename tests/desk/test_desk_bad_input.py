"""Bad input to the Desk over HTTPS: each is refused alone (a 4xx with a JSON reason and one log
line), the Desk unchanged, and it serves on; the end effector's power as the Desk switches it
(the Hand's service stops answering)."""

from __future__ import annotations

import base64
import http.client
import json
import socket
import ssl

import pylibfranka
import pytest

from franka_sim.control import Control
from franka_sim.testing import running_sim

PORT = 8443
BASIC = {"Authorization": "Basic " + base64.b64encode(b"franka:franka").decode()}


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    data = tmp_path_factory.mktemp("desk-data")
    with running_sim("--desk-port", str(PORT), "--control-port", "1340",
                     env={"XDG_DATA_HOME": str(data)}) as served:
        yield served


def _request(host, method, path, body=None, headers=BASIC):
    connection = http.client.HTTPSConnection(
        host, PORT, timeout=30, context=ssl._create_unverified_context())
    try:
        connection.request(method, path, body=body, headers=headers)
        response = connection.getresponse()
        data = response.read()
        return response.status, json.loads(data) if data else None
    finally:
        connection.close()


def _take(host) -> str:
    status, body = _request(host, "POST", "/api/system/control-token:take",
                            json.dumps({"owner": "t", "timeout": 1}))
    assert status == 200, body
    return body["token"]


def test_the_default_user_is_served(sim):
    assert _request(sim.host, "GET", "/api/fci") == (200, {"status": "Active"})


def test_a_wrong_password_is_401_and_changes_nothing(sim):
    before = Control(sim.host).desk()
    wrong = {"Authorization": "Basic " + base64.b64encode(b"franka:wrong").decode()}
    status, body = _request(sim.host, "POST", "/api/system/control-token:take",
                            json.dumps({"owner": "x", "timeout": 1}), headers=wrong)
    assert status == 401 and body["error"]
    assert Control(sim.host).desk() == before
    assert any("401" in line and "refused" in line for line in sim.sync())


def test_an_unknown_endpoint_is_404_with_a_reason(sim):
    status, body = _request(sim.host, "GET", "/api/warp-drive")
    assert status == 404 and "/api/warp-drive" in body["error"]
    status, body = _request(sim.host, "GET", "/api/a%0Afake")  # (a newline in the path)
    assert status == 404 and "/api/a\nfake" in body["error"]
    assert len(sim.wait_for_log("/api/a\\nfake")) == 1  # one line, the newline escaped
    status, body = _request(sim.host, "GET", "/desk/api/navigation/events")  # not a WebSocket
    assert status == 400 and "WebSocket" in body["error"]


def test_a_malformed_body_is_400(sim):
    for raw in (b"{not json", b"[]", json.dumps({"owner": "x", "timeout": "soon"}).encode(),
                b"[" * 5000):  # (nested past the parser's recursion)
        status, body = _request(sim.host, "POST", "/api/system/control-token:take", raw)
        assert status == 400 and body["error"], raw
    status, body = _request(sim.host, "POST", "/api/system/control-token:take", b"null")
    assert status == 400 and "expected a JSON object, not null" in body["error"]
    assert Control(sim.host).desk()["control_token"] is None
    status, body = _request(sim.host, "POST", "/api/system/control-token:take",
                            b"{" + b" " * 70000 + b"}")
    assert status == 413 and body["error"]


def test_garbage_instead_of_tls_costs_that_connection_only(sim):
    for garbage in (b"GET / HTTP/1.1\r\nHost: x\r\n\r\n", bytes(range(256)) * 4):
        with socket.create_connection((sim.host, PORT), timeout=10) as raw:
            raw.sendall(garbage)
            raw.shutdown(socket.SHUT_WR)
            while raw.recv(4096):
                pass
    assert _request(sim.host, "GET", "/api/fci") == (200, {"status": "Active"})
    assert sim.wait_for_log("TLS handshake refused (WRONG_VERSION_NUMBER)")
    assert sim.wait_for_log("TLS handshake refused (HTTP_REQUEST)")


def test_an_unpowered_end_effector_does_not_answer(sim):
    Control(sim.host).reset()
    pylibfranka.Gripper(sim.host)  # powered: it answers
    token = _take(sim.host)
    assert _request(sim.host, "POST", "/api/end-effector/power:off",
                    headers={**BASIC, "X-Control-Token": token})[0] == 200
    with pytest.raises(pylibfranka.NetworkException):
        pylibfranka.Gripper(sim.host)
    assert _request(sim.host, "POST", "/api/end-effector/power:on",
                    headers={**BASIC, "X-Control-Token": token})[0] == 200
    gripper = pylibfranka.Gripper(sim.host)
    assert gripper.read_once().max_width > 0.07
    del gripper
    Control(sim.host).reset()


def test_a_take_says_what_its_body_lacks(sim):
    for body, reason in [({"owner": "t"}, "no timeout"),
                         ({"owner": 5, "timeout": 1}, "owner 5: expected the requester's name"),
                         ({"owner": "", "timeout": 1}, "owner '': expected"),
                         ({"owner": "t", "timeout": 10 ** 5000}, "a number of 5001 digits")]:
        raw = json.dumps(body).encode() if "timeout" not in body or body["timeout"] != 10 ** 5000 \
            else b'{"owner": "t", "timeout": 1' + b"0" * 5000 + b"}"
        status, answer = _request(sim.host, "POST", "/api/system/control-token:take", raw)
        assert status == 400 and reason in answer["error"], (body, answer)
    assert Control(sim.host).desk()["control_token"] is None


def test_a_request_line_aiohttp_refuses_is_one_warning(sim):
    """Not a method at all: the HTTP layer's 400, said in one line as every refusal is."""
    sim.sync()
    context = ssl._create_unverified_context()
    with socket.create_connection((sim.host, PORT), timeout=10) as raw:
        with context.wrap_socket(raw) as tls:
            tls.sendall(b"FOO{} / HTTP/1.1\r\nHost: x\r\n\r\n")
            answer = tls.recv(4096)
    assert answer.startswith(b"HTTP/1.") and b" 400 " in answer.split(b"\r\n")[0]
    lines = sim.wait_for_log("refused (400)")
    assert len(lines) == 1 and "HTTP request from 127." in lines[0], lines
    assert _request(sim.host, "GET", "/api/fci") == (200, {"status": "Active"})


def test_the_desks_homing_of_an_arm_without_a_hand_is_409(tmp_path):
    """Refused before anything is applied, in one line (as with the Hand busy:
    test_desk_state.py)."""
    with running_sim("--desk-port", str(PORT), "--tool", "none",
                     env={"XDG_DATA_HOME": str(tmp_path)}) as sim:
        token = _take(sim.host)
        status, body = _request(sim.host, "POST", "/desk/api/gripper/homing",
                                headers={**BASIC, "X-Control-Token": token})
        assert status == 409 and "no Franka Hand on this arm" in body["error"], body
        lines = [line for line in sim.sync() if "/desk/api/gripper/homing" in line]
        assert len(lines) == 1 and "refused (409 Conflict)" in lines[0], lines
