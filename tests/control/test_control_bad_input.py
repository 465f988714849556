"""Bad input to the control API, as raw HTTP: each gets its 4xx with a JSON error and one log
line saying what was wrong, nothing changes, and the robot's stream goes on."""

from __future__ import annotations

import http.client
import json
import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import Control
from support.clients import connect

PUSH = {"body": "hand", "force": [1.0, 0.0, 0.0], "duration": 0.1}
CUBE = "/bodies/scene/cube"

HUGE = b"1" + b"0" * 400  # an integer past any float (JSON has no bound on integers)
BAD = [  # (method, path, body, status, what the error says)
    ("POST", "/push", b"{", 400, "malformed JSON"),
    ("POST", "/push", b"[1, 2]", 400, "expected a JSON object, not an array"),
    ("POST", "/reset", b"null", 400, "expected a JSON object, not null"),
    ("POST", "/push", b"", 400, "expected a JSON object"),
    ("POST", "/push", b"\xff\xfe", 400, "malformed JSON"),
    ("POST", "/push", {**PUSH, "speed": 3}, 400, "unknown field(s) 'speed'"),
    ("POST", "/push", {"body": "hand"}, 400, "missing field(s) 'force'"),
    ("POST", "/push", {**PUSH, "force": [1.0, 2.0]}, 400, "force must have 3 numbers"),
    ("POST", "/push", {**PUSH, "force": "up"}, 400, "force must be a list of 3 numbers"),
    ("POST", "/push", {**PUSH, "force": ["a", 0, 0]}, 400, "force must be 3 numbers"),
    ("POST", "/push", {**PUSH, "force": [True, 0, 0]}, 400, "force must be 3 numbers"),
    ("POST", "/push", b'{"body": "hand", "force": [NaN, 0, 0]}', 400, "NaN is not a JSON"),
    ("POST", "/push", b'{"body": "hand", "force": [1e999, 0, 0]}', 400, "force must be finite"),
    ("POST", "/push", {**PUSH, "torque": [0, 0, None]}, 400, "torque must be 3 numbers"),
    ("POST", "/push", b'{"body": "hand", "force": [%s, 0, 0]}' % HUGE, 400,
     "force must be finite"),
    ("POST", "/push", b'{"body": "hand", "force": [1, 0, 0], "duration": %s}' % HUGE, 400,
     "duration must be finite"),
    ("POST", "/reset", b'{"gripper_width": %s}' % HUGE, 400, "gripper_width must be finite"),
    # (past these the step fails, and the server with it, or the arm is torn past its limits)
    ("POST", "/push", {**PUSH, "force": [0, 0, 1e6]}, 400, "force 1e+06 N is over the 1000 N"),
    ("POST", "/push", {**PUSH, "force": [800, 800, 0]}, 400, "force 1131.37 N is over"),
    ("POST", "/push", {**PUSH, "torque": [0, 150, 0]}, 400, "torque 150 Nm is over the 100 Nm"),
    ("POST", "/push", {**PUSH, "duration": -0.5}, 400, "duration must be positive"),
    ("POST", "/push", {**PUSH, "duration": 0}, 400, "duration must be positive"),
    ("POST", "/push", {**PUSH, "duration": "1s"}, 400, "duration must be a number"),
    ("POST", "/push", {**PUSH, "duration": 1e300}, 400, "duration 1e+300 s is over the 60 s"),
    ("POST", "/push", {**PUSH, "body": 7}, 400, "body must be a body's name"),
    ("POST", "/push", {**PUSH, "body": "link9"}, 404, "no body named 'link9'"),
    # what the 1 ms step cannot integrate: the 0.1 kg cube at 20 m/s, spun at 2500 rad/s
    ("POST", "/push", {"body": "cube", "force": [0, 20, 0], "duration": 0.1}, 400,
     "would move scene/cube (0.1 kg) at up to 20 m/s"),
    ("POST", "/push", {"body": "cube", "force": [0, 0, 0], "torque": [0, 0, 0.1],
                       "duration": 1.0}, 400, "would spin scene/cube (0.1 kg) at up to"),
    ("GET", "/bodies/link9", None, 404, "no body named 'link9'"),
    ("PUT", "/bodies/link9", {"position": [0, 0, 1]}, 404, "no body named 'link9'"),
    ("PUT", "/bodies/link3", {"position": [0, 0, 1]}, 409, "'link3' is not a free body"),
    ("PUT", "/bodies/scene/table", {"position": [0, 0, 1]}, 409,
     "'scene/table' is not a free body: it is fixed to the world"),
    ("POST", "/push", {**PUSH, "body": "scene/table"}, 409,
     "'scene/table' does not move under a push: it is fixed to the world"),
    ("PUT", CUBE, {"position": [0, 0]}, 400, "position must have 3 numbers"),
    ("PUT", CUBE, {"position": [1e20, 0, 0.1]}, 400, "position 1e+20 m is over the 100 m"),
    ("PUT", CUBE, {"quaternion": [1, 0, 0, 0]}, 400, "missing field(s) 'position'"),
    ("PUT", CUBE, {"position": [0.4, 0, 0.3], "quaternion": [0, 0, 0, 0]}, 400,
     "quaternion must not be zero"),
    ("PUT", CUBE, {"position": [0.4, 0, 0.3], "pose": 1}, 400, "unknown field(s) 'pose'"),
    ("POST", "/reset", {"q": [0.0] * 6}, 400, "q must have 7 numbers"),
    ("POST", "/reset", {"q": [3.0] * 7}, 400, "outside the joint limits"),
    ("POST", "/reset", {"gripper_width": 0.5}, 400, "gripper_width 0.5 m is outside"),
    ("POST", "/reset", {"gripper_width": "wide"}, 400, "gripper_width must be a number"),
    ("POST", "/reset", {"q0": [0.0] * 7}, 400, "unknown field(s) 'q0'"),
    ("POST", "/reset", b"null", 400, "expected a JSON object"),
    ("GET", "/nothing", None, 404, "no resource /nothing"),
    ("DELETE", "/state", None, 405, "DELETE is not allowed on /state"),
    ("POST", "/push", b"[" * 70000, 413, "Too Large"),
    ("POST", "/reset", b"[" * 5000, 400, "malformed JSON: nested too deeply"),
]


def request(host: str, method: str, path: str, body=None) -> tuple[int, dict]:
    if body is not None and not isinstance(body, bytes):
        body = json.dumps(body).encode()
    connection = http.client.HTTPConnection(host, 1340, timeout=10)
    try:
        connection.request(method, path, body)
        response = connection.getresponse()
        return response.status, json.loads(response.read())
    finally:
        connection.close()


@pytest.fixture(scope="module")
def watched(served):
    """A client connected through all the bad requests: its stream must go on."""
    robot = connect(served.host)
    yield robot
    del robot


@pytest.fixture(scope="module")
def at_rest(served) -> Control:
    """The world reset once and come to rest (the cube asleep on the table): from then on,
    anything that moves was moved by a request."""
    control = Control(served.host)
    control.reset()
    end, last = time.monotonic() + 30, None
    while True:  # (a read right after the reset finds it still, before it has settled)
        pose = control.pose("cube")
        if pose == last and not any(pose["linear_velocity"]):
            return control
        assert time.monotonic() < end, "the cube does not come to rest"
        last = pose
        time.sleep(0.05)


@pytest.mark.parametrize(("method", "path", "body", "status", "says"), BAD,
                         ids=[f"{k}-{m}-{s}" for k, (m, _, _, s, _) in enumerate(BAD)])
def test_bad_input_is_refused_and_changes_nothing(served, watched, at_rest, method, path, body,
                                                 status, says):
    control = at_rest
    before = control.state(), control.pose("cube"), control.pose("hand")
    refusals = len(served.log_matching("refused"))
    got, answer = request(served.host, method, path, body)
    assert got == status
    assert list(answer) == ["error"] and says in answer["error"]
    end = time.monotonic() + 10
    while len(served.log_matching("refused")) == refusals and time.monotonic() < end:
        time.sleep(0.005)
    after = control.state(), control.pose("cube"), control.pose("hand")
    assert after[0]["q"] == before[0]["q"] and after[0]["errors"] == []
    assert after[1:] == before[1:]
    assert watched.read_once().robot_mode == pylibfranka.RobotMode.Idle
    logged = served.log_matching("refused")[refusals:]
    assert len(logged) == 1  # one line per refusal, naming what was wrong
    assert f"{method} {path} refused ({status})" in logged[0]
    assert says.split("'")[0] in logged[0]


def test_what_a_client_sends_is_logged_on_its_own_line_escaped(served):
    """A path with a newline and a terminal escape in it: one line, the characters escaped,
    not a line that reads as the server's own nor a cleared screen."""
    forged = "2026-01-01 00:00:00,000 INFO franka_sim: forged"
    got, answer = request(served.host, "GET", "/x%0A" + forged.replace(" ", "%20") + "%1b%5b2J")
    assert got == 404 and answer["error"].startswith("no resource /x\n2026-01-01")
    logged = served.wait_for_log("no resource /x")
    assert len(logged) == 1 and "/x\\n2026-01-01 00:00:00,000 INFO" in logged[0]
    assert "\\x1b[2J" in logged[0] and "\x1b" not in logged[0]
    assert not any(line.startswith("2026-01-01") for line in served.sync())


MALFORMED_HTTP = [  # what aiohttp's own parser refuses before a handler sees it, and its line
    (b"POST /reset HTTP/1.1\r\nHost: x\r\nContent-Length: abc\r\n\r\n{}",
     "refused (400): Invalid character in Content-Length"),
    (b"POST /reset HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n{}\r\n0\r\n\r\n",
     "refused (400): Invalid character in chunk size"),
    (b"GET /health HTTP/1.1\r\nHost: x\r\n" + b"X-A: b\r\n" * 500 + b"\r\n",
     "refused (400): Too many headers"),
    (b"POST /reset HTTP/1.1\r\nHost: x\r\nContent-Encoding: gzip\r\nContent-Length: 2\r\n\r\n{}",
     "refused (400): the request's body cannot be read: Can not decode content-encoding: gzip"),
]


@pytest.mark.parametrize(("raw", "line"), MALFORMED_HTTP,
                         ids=["length", "chunk", "headers", "gzip"])
def test_malformed_http_is_one_line_each_and_serving_goes_on(served, watched, raw, line):
    import socket

    before = len(served.sync())
    with socket.create_connection((served.host, 1340), timeout=10) as sock:
        sock.sendall(raw)
        assert b" 400 " in sock.recv(100).split(b"\r\n")[0]
    logged = served.wait_for_log(line)
    assert len(logged) == 1
    new = served.sync()[before:]
    assert not any("Traceback" in text for text in new), "\n".join(new)
    assert watched.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_a_client_that_hangs_up_mid_body_is_one_line(served):
    import socket

    with socket.create_connection((served.host, 1340), timeout=10) as sock:
        sock.sendall(b"POST /reset HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{")
    logged = served.wait_for_log("the client left before its request was whole")
    assert len(logged) == 1 and "POST /reset" in logged[0]
    assert Control(served.host).health()["ready"]


def test_a_quaternion_of_huge_numbers_is_normalised_without_overflow(served, at_rest):
    """[1e308, 1e308, 0, 0] is the turn [0.707, 0.707, 0, 0]: its norm overflows unless scaled
    first (it was placed unturned, and numpy's overflow warnings went to the log)."""
    control = at_rest
    before = len(served.sync())
    try:
        placed = control.set_pose("cube", [0.45, 0.0, 0.3], [1e308, 1e308, 0, 0])
        np.testing.assert_allclose(placed["quaternion"], [0.5 ** 0.5, 0.5 ** 0.5, 0, 0],
                                   atol=1e-9)
        assert not any("RuntimeWarning" in line for line in served.sync()[before:])
    finally:
        control.set_pose("cube", [0.45, 0.0, 0.025], [1, 0, 0, 0])
