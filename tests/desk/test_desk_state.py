"""The Desk as plain Python (desk/): the calls both dialects make, what they change and what
they refuse, without a socket; and the arm it holds (robot mode Other, a Move refused)."""

from __future__ import annotations

import base64
import json

import pytest

from franka_sim.desk.calls import Call
from franka_sim.desk.service import DeskService
from franka_sim.desk.state import Desk
from franka_sim.desk.users import Users, browser_password
from franka_sim.protocol.enums import MoveStatus, RobotMode

from support.harness import Harness

USER, PASSWORD = "admin", "secret"
BASIC = "Basic " + base64.b64encode(f"{USER}:{PASSWORD}".encode()).decode()


def _service(boot: str = "locked") -> DeskService:
    secrets = iter(f"secret-{n}" for n in range(1, 100))
    return DeskService(Desk(boot=boot, new_secret=lambda: next(secrets)),
                       Users({USER: PASSWORD}))


def _call(service, method, path, body=None, *, token=None, auth=BASIC, query=None,
          raw: bytes | None = None, form: bool = False):
    headers = {} if auth is None else {"authorization": auth}
    if token is not None:
        headers["x-control-token"] = token
    data = raw if raw is not None else b"" if body is None else (
        "&".join(f"{k}={v}" for k, v in body.items()).encode() if form
        else json.dumps(body).encode())
    answer = service.handle(Call(method, path, query or {}, headers, data))
    if answer.request is not None:  # a take: the adapter would wait; here nothing changes
        if not answer.request.granted:
            service.desk.withdraw(answer.request)
        answer = service.finish(Call(method, path), answer)
    return answer


def _take(service, owner=USER) -> str:
    answer = _call(service, "POST", "/api/system/control-token:take",
                   {"owner": owner, "timeout": 1})
    assert answer.status == 200, answer.body
    return answer.body["token"]


def test_locked_boot_is_the_robot_after_power_on():
    service = _service("locked")
    assert _call(service, "GET", "/api/system").body["operatingMode"] == {"status": "Programming"}
    assert _call(service, "GET", "/api/fci").body == {"status": "Inactive"}
    assert {j["brakeStatus"] for j in _call(service, "GET", "/api/arm/joints").body} == {"Locked"}
    assert not service.desk.arm_ready
    assert Desk(boot="ready").arm_ready and Desk(boot="ready").fci_active


def test_bring_up_and_tear_down_change_the_desk():
    service = _service()
    token = _take(service)
    for path, body in (("/api/arm/joints:unlock", None),
                       ("/api/system/operating-mode:change", {"desiredOperatingMode": "Execution"}),
                       ("/api/fci:activate", None)):
        assert _call(service, "POST", path, body, token=token).status == 200
    desk = service.desk
    assert desk.arm_ready and desk.fci_active
    for path in ("/api/fci:deactivate", "/api/arm/joints:lock",
                 "/api/system/control-token:release"):
        assert _call(service, "POST", path, token=token).status == 200
    assert not desk.fci_active and desk.brakes == "Locked" and desk.token is None


def test_a_second_take_waits_until_released_and_a_forced_one_for_the_pilot():
    service = _service()
    first = _take(service, "first")
    refused = _call(service, "POST", "/api/system/control-token:take",
                    {"owner": "second", "timeout": 1})
    assert (refused.status, refused.body["code"]) == (424, "Timeout")
    assert service.desk.token.owner == "first"
    # The older Desk's request waits (answered at once; its id is not the active one yet).
    waiting = _call(service, "POST", "/admin/api/control-token/request", {"requestedBy": "second"})
    assert waiting.status == 200 and service.desk.token.owner == "first"
    _call(service, "POST", "/api/system/control-token:release", token=first)
    assert service.desk.token.id == waiting.body["id"]
    # Forced: only a press of the Pilot's circle hands it over; another button does not.
    forced = _call(service, "POST", "/admin/api/control-token/request", {"requestedBy": "third"},
                   query={"force": ""})
    service.desk.press("check")
    assert service.desk.token.owner == "second"
    service.desk.press("circle")
    assert service.desk.token.id == forced.body["id"] and service.desk.pending is None
    status = _call(service, "GET", "/admin/api/system-status").body
    assert status["controlToken"]["activeToken"] == {"id": forced.body["id"], "ownedBy": "third"}


def test_a_waiting_take_replaced_by_a_later_one_is_refused_saying_so():
    service = _service()
    first = _take(service, "first")

    def take(owner: str):  # (what the adapter hands over, before it waits)
        body = json.dumps({"owner": owner, "timeout": 6}).encode()
        return service.handle(Call("POST", "/api/system/control-token:take", {},
                                   {"authorization": BASIC}, body))

    waiting = take("E")
    later = take("F")
    refused = service.finish(Call("POST", "/api/system/control-token:take"), waiting)
    assert (refused.status, refused.body["code"]) == (424, "Timeout")
    assert "a later request for it replaced this one" in refused.body["message"]
    _call(service, "POST", "/api/system/control-token:release", token=first)
    assert later.request.granted and service.desk.token.owner == "F"


def test_a_panda_boots_in_execution_and_refuses_programming():
    from franka_sim.desk.state import DeskRefusal

    desk = Desk(boot="locked", robot="fer", new_secret=lambda: "secret")
    assert (desk.brakes, desk.operating_mode) == ("Locked", "Execution")
    token = desk.take("someone").token.secret
    with pytest.raises(DeskRefusal, match="a Panda has no Programming mode"):
        desk.set_operating_mode(token, "Programming")
    with pytest.raises(DeskRefusal, match="a Panda has no Programming mode"):
        desk.set_arm(brakes="Unlocked", operating_mode="Programming")
    assert (desk.brakes, desk.operating_mode) == ("Locked", "Execution")  # (nothing changed)


def test_the_pilot_is_heard_pressed_then_released():
    desk, heard = Desk(), []
    desk.listeners.append(heard.append)
    desk.press("up")
    assert heard == [{"up": True}, {"up": False}]


def test_changes_need_the_holders_token():
    service = _service()
    _take(service)
    for token in (None, "not-it"):
        answer = _call(service, "POST", "/api/arm/joints:unlock", token=token)
        assert answer.status == 403 and answer.body["code"] in (
            "MissingControlToken", "InvalidControlToken")
    assert service.desk.brakes == "Locked"


def test_the_older_desk_logs_in_and_sends_its_session():
    service = _service()
    login = _call(service, "POST", "/admin/api/login",
                  {"login": USER, "password": browser_password(USER, PASSWORD)}, auth=None)
    assert login.status == 200 and login.text
    cookie = {"cookie": f"authorization={login.text}"}
    answer = service.handle(Call("POST", "/admin/api/control-token/request", {}, dict(cookie),
                                 json.dumps({"requestedBy": USER}).encode()))
    token = answer.body["token"]
    for path in ("/desk/api/joints/unlock", "/desk/api/operating-mode/execution"):
        headers = dict(cookie, **{"x-control-token": token})
        assert service.handle(Call("POST", path, {}, headers, b"")).status == 200
    fci = base64.b64encode(token.encode()).decode()
    assert service.handle(Call("POST", "/desk/api/system/fci", {}, dict(cookie),
                               f"token={fci}".encode())).status == 200
    assert service.desk.arm_ready and service.desk.fci_active
    assert service.handle(Call("DELETE", "/desk/api/system/fci", {},
                               dict(cookie, **{"x-control-token": token}), b"")).status == 200
    assert not service.desk.fci_active


@pytest.mark.parametrize("auth", [None, "Basic " + base64.b64encode(b"admin:wrong").decode(),
                                  "Basic !!!", "Bearer x"])
def test_wrong_credentials_answer_401_and_change_nothing(auth):
    service = _service()
    before = service.desk.snapshot()
    answer = _call(service, "POST", "/api/system/control-token:take",
                   {"owner": "x", "timeout": 1}, auth=auth)
    assert answer.status == 401 and answer.body["error"]
    assert service.desk.snapshot() == before
    login = _call(service, "POST", "/admin/api/login", {"login": USER, "password": "wrong"},
                  auth=None)
    assert login.status == 401


def test_unknown_malformed_and_misplaced_calls():
    service = _service()
    unknown = _call(service, "GET", "/api/teleport")
    assert unknown.status == 404 and "/api/teleport" in unknown.body["error"]
    assert _call(service, "GET", "/api/fci:activate").status == 405
    for raw in (b"{", b"[1]", b"\xff"):
        answer = _call(service, "POST", "/api/system/control-token:take", raw=raw)
        assert answer.status == 400, raw
    for timeout in (0, -1, "1", True, 1e9):
        answer = _call(service, "POST", "/api/system/control-token:take",
                       {"owner": "x", "timeout": timeout})
        assert answer.status == 400, timeout
    token = _take(service)
    bad_mode = _call(service, "POST", "/api/system/operating-mode:change",
                     {"desiredOperatingMode": "Dancing"}, token=token)
    assert bad_mode.status == 400 and service.desk.operating_mode == "Programming"


def test_self_tests_need_locked_brakes():
    service = _service()
    token = _take(service)
    assert _call(service, "POST", "/api/safety/self-tests:execute", token=token).status == 200
    assert _call(service, "GET", "/api/safety/self-tests").body == {"status": "Finished"}
    _call(service, "POST", "/api/arm/joints:unlock", token=token)
    refused = _call(service, "POST", "/api/safety/self-tests:execute", token=token)
    assert refused.status == 424 and refused.body["details"] == ["BrakesOpen"]


def test_a_held_arm_reads_other_and_refuses_a_move():
    robot = Harness()
    robot.core.hold(True)
    assert int(robot.cycle()["robot_mode"]) == RobotMode.kOther
    assert robot.move() == MoveStatus.kCommandNotPossibleRejected
    robot.core.hold(False)
    assert int(robot.cycle()["robot_mode"]) == RobotMode.kIdle
    assert robot.move() == MoveStatus.kMotionStarted


def test_holding_a_moving_arm_aborts_its_motion():
    robot = Harness()
    assert robot.move() == MoveStatus.kMotionStarted
    robot.cycle()
    robot.core.hold(True)
    robot.cycle()
    assert (5, 0, MoveStatus.kAborted) in [(cid, 0, status) for _, cid, status in
                                            robot.statuses()]
    assert robot.core.motion is None and int(robot.state["robot_mode"]) == RobotMode.kOther


def test_the_older_desk_answers_what_panda_pythons_desk_asks():
    """panda-python 1.1.1's `Desk`: a forced take reads how long its requester has to press
    the Pilot's button (/admin/api/safety), `deactivate_fci` DELETEs the FCI with the token in
    its body, and `lock` closes the brakes with its session alone."""
    service = _service()
    login = _call(service, "POST", "/admin/api/login",
                  {"login": USER, "password": browser_password(USER, PASSWORD)}, auth=None)
    cookie = {"cookie": f"authorization={login.text}"}

    def call(method, path, body=b"", **headers):
        return service.handle(Call(method, path, {}, dict(cookie, **headers), body))

    safety = call("GET", "/admin/api/safety")
    assert safety.status == 200 and safety.body["tokenForceTimeout"] > 0
    token = call("POST", "/admin/api/control-token/request",
                 json.dumps({"requestedBy": USER}).encode()).body["token"]
    for path in ("/desk/api/robot/open-brakes", "/desk/api/operating-mode/execution"):
        assert call("POST", path, **{"x-control-token": token}).status == 200
    body = json.dumps({"token": token}).encode()
    assert call("POST", "/admin/api/control-token/fci", body).status == 200
    assert service.desk.fci_active
    assert call("DELETE", "/admin/api/control-token/fci", body).status == 200
    assert not service.desk.fci_active
    assert call("DELETE", "/admin/api/control-token/fci", b'{"token": "not-it"}').status == 403
    assert call("POST", "/desk/api/robot/close-brakes").status == 200
    assert service.desk.brakes == "Locked"


def test_a_homing_the_hand_cannot_start_is_refused_before_it_is_applied():
    """The Desk's homing with no Hand on the arm, or the Hand's action under way: refused,
    saying which, and dropped (not started once the Hand is free)."""
    from types import SimpleNamespace

    from franka_sim.server.desk_effects import DeskEffects

    service = _service("ready")
    hand = SimpleNamespace(busy=True)
    control = SimpleNamespace(desk_state=service.desk, hand=hand)
    effects = DeskEffects(SimpleNamespace(control=control))
    token = _take(service)
    assert effects.homing_refused() is None  # none asked for
    assert _call(service, "POST", "/desk/api/gripper/homing", token=token).status == 200
    assert "the Hand is busy" in effects.homing_refused()
    hand.busy = False
    assert effects.homing_refused() is None and effects.homings == 1  # dropped
    assert _call(service, "POST", "/desk/api/gripper/homing", token=token).status == 200
    assert effects.homing_refused() is None and effects.homings == 1  # this one goes
    control.hand = None
    assert _call(service, "POST", "/desk/api/gripper/homing", token=token).status == 200
    assert "no Franka Hand on this arm" in effects.homing_refused()

