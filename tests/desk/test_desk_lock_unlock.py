"""The older Desk as a Panda's system 4 has it, through the franka_lock_unlock script (a
Python script a lab keeps beside its code, not a package: point FRANKA_SIM_LOCK_UNLOCK at
your copy of `franka_lock_unlock.py` to run it here; without it those tests skip) and through
the calls it makes, sent as it sends them: token, brakes, FCI, the Hand's homing, logout; and
the Hand homed through the control API."""

from __future__ import annotations

import base64
import json
import os
import signal
import ssl
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pylibfranka
import pytest

from franka_sim.control import Conflict, Control
from franka_sim.desk.users import browser_password
from desk.conftest import PASSWORD, PORT, USER, locked_desk
from support.clients import connect

SCRIPT = os.environ.get("FRANKA_SIM_LOCK_UNLOCK")


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    with locked_desk(tmp_path_factory, "--robot", "fer") as sim:
        yield sim


@pytest.fixture
def sim(served):
    Control(served.host).reset()
    return served


def _call(host: str, method: str, path: str, body=None, headers=None, cookie=None):
    """One HTTPS call as requests makes it (the robot's self-signed certificate accepted)."""
    data = json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(f"https://{host}:{PORT}{path}", data=data, method=method,
                                     headers={"Content-Type": "application/json",
                                              **({"Cookie": f"authorization={cookie}"}
                                                 if cookie else {}), **(headers or {})})
    with urllib.request.urlopen(request, context=ssl._create_unverified_context(),
                                timeout=30) as answer:
        text = answer.read().decode()
    return json.loads(text) if text.startswith(("{", "[")) else text


def test_the_rest_api_names_the_arm_a_fer(sim):
    basic = "Basic " + base64.b64encode(f"{USER}:{PASSWORD}".encode()).decode()
    headers = {"Authorization": basic}
    assert _call(sim.host, "GET", "/api/system", headers=headers)["armType"] == "FER"
    assert _call(sim.host, "GET", "/api/arm", headers=headers)["type"] == "FER"


def test_system_4s_calls_bring_a_panda_up_and_home_its_hand(sim):
    host, desk = sim.host, Control(sim.host)
    session = _call(host, "POST", "/admin/api/login",
                    {"login": USER, "password": browser_password(USER, PASSWORD)})
    assert _call(host, "GET", "/admin/api/control-token", cookie=session) == \
        {"activeToken": None}
    token = _call(host, "POST", "/admin/api/control-token/request", {"requestedBy": USER},
                  cookie=session)
    assert _call(host, "GET", "/admin/api/control-token", cookie=session)["activeToken"][
        "id"] == token["id"]
    with_token = {"X-Control-Token": token["token"]}
    _call(host, "POST", "/desk/api/robot/open-brakes", headers=with_token, cookie=session)
    _call(host, "POST", "/admin/api/control-token/fci", {"token": token["token"]},
          cookie=session)
    _call(host, "POST", "/desk/api/gripper/homing", headers=with_token, cookie=session)
    state = desk.desk()
    assert (state["brakes"], state["fci"]) == ("Unlocked", "Active")
    gripper = _gripper(host)
    assert _settled_width(gripper) > 0.07  # homed: open to its full width
    del gripper  # (the Hand takes one client: the next test's)
    _call(host, "POST", "/desk/api/robot/close-brakes", headers=with_token, cookie=session)
    _call(host, "DELETE", "/admin/api/control-token", {"token": token["token"]},
          cookie=session)
    _call(host, "POST", "/admin/api/logout", cookie=session)
    with pytest.raises(urllib.error.HTTPError) as refused:  # the session ended
        _call(host, "GET", "/admin/api/control-token", cookie=session)
    assert refused.value.code == 401
    assert desk.desk()["brakes"] == "Locked"


def _gripper(host: str) -> pylibfranka.Gripper:
    """A Hand client, once the previous test's has been seen gone (the Hand takes one)."""
    for _ in range(100):
        try:
            return pylibfranka.Gripper(host)
        except pylibfranka.NetworkException:
            time.sleep(0.05)
    return pylibfranka.Gripper(host)


def _settled_width(gripper: pylibfranka.Gripper) -> float:
    """The Hand's width once a homing nobody awaits has ended (its state stops changing)."""
    widths = [gripper.read_once().width]
    while len(widths) < 3 or abs(widths[-1] - widths[-3]) > 1e-6:
        widths.append(gripper.read_once().width)
    return widths[-1]


def test_the_control_api_homes_the_hand_and_refuses_while_a_client_action_runs(sim):
    control = Control(sim.host)
    assert control.home_gripper() == {"homing": True}
    with pytest.raises(Conflict, match="busy"):
        control.home_gripper()  # its own homing still runs
    assert control.state()["gripper_busy"]  # (what an embedder waits on: its end)
    end = time.monotonic() + 30
    while control.state()["gripper_busy"] and time.monotonic() < end:
        time.sleep(0.05)
    assert not control.state()["gripper_busy"]
    gripper = _gripper(sim.host)
    assert _settled_width(gripper) > 0.07
    assert gripper.move(0.02, 0.1)  # a client's action after it is answered as ever


@pytest.mark.skipif(not (SCRIPT and Path(SCRIPT).is_file()),
                    reason="FRANKA_SIM_LOCK_UNLOCK does not name franka_lock_unlock.py")
def test_franka_lock_unlock_unlocks_activates_the_fci_and_homes(sim):
    """`franka_lock_unlock.py HOST USER PASSWORD -u -p -c -i`: unlock, FCI, homing, then it
    keeps the token until interrupted, when it releases it and logs out."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("REQUESTS_CA_BUNDLE", "CURL_CA_BUNDLE")}  # (they override verify=False)
    script = subprocess.Popen([sys.executable, SCRIPT, f"{sim.host}:{PORT}", USER, PASSWORD,
                               "-u", "-p", "-c", "-i"], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, env=env)
    try:
        lines = []
        for line in script.stdout:
            lines.append(line)
            if "Keeping persistent connection" in line:
                break
        assert "Successfully activated FCI." in "".join(lines), "".join(lines)
        robot = connect(sim.host)  # the FCI is active and the brakes open
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot
        assert _settled_width(_gripper(sim.host)) > 0.07
    finally:
        script.send_signal(signal.SIGINT)  # its cleanup releases the token and logs out
        out, _ = script.communicate(timeout=30)
    assert "Successfully cleaned up." in out
    assert Control(sim.host).desk()["control_token"] is None
