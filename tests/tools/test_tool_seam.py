"""The end-effector tool seam: every tool a row of franka_sim/tools/, each row's pieces keeping
the contracts the arm's cycle, its physics and the server use (robot/tool.py, physics/tool.py),
and `--tool none` (alias `--no-gripper`) a robot whose tool answers nothing."""

from __future__ import annotations

import inspect
import socket

import numpy as np
import pylibfranka
import pytest

from franka_sim.config import READY_POSE, ToolName
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.tool import ToolAttachment, ToolMount
from franka_sim.robot.tool import ToolDevice
from franka_sim.testing import running_sim
from franka_sim.tools import NO_TOOL, tool_kind, tool_kinds

DESC = load_arm_description(default_urdf_text())


def _members(protocol) -> set[str]:
    return {name for name, _ in inspect.getmembers(protocol) if not name.startswith("_")}


def test_the_cli_offers_every_tool_and_only_them():
    assert {t.value for t in ToolName} == {*tool_kinds(), NO_TOOL}
    assert tool_kind(NO_TOOL) is None
    with pytest.raises(KeyError, match="one of"):
        tool_kind("vacuum cleaner")


@pytest.mark.parametrize("name", sorted(tool_kinds()))
def test_each_tool_keeps_the_contracts(name):
    kind = tool_kinds()[name]
    device = kind.make_device()
    assert _members(ToolDevice) <= set(dir(device)), name
    assert _members(ToolMount) <= set(dir(kind.mount)), name
    backend = MujocoBackend(DESC, np.array(READY_POSE), tool=kind.mount)
    attachment = backend.arm.tool
    assert _members(ToolAttachment) <= set(dir(attachment)), name
    reading = backend.measure().tool
    assert reading is not None  # what the device advances on
    device.advance(1, reading)
    assert device.idle and not device.busy
    assert kind.service.name and kind.port not in (1337, 1340)


@pytest.mark.parametrize("flags", [("--tool", "none"), ("--no-gripper",)])
def test_without_a_tool_its_port_refuses_and_the_robot_serves(flags):
    with running_sim(*flags) as sim:
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection((sim.host, 1338), timeout=5).close()
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        assert sim.log_matching("no tool")


def test_no_gripper_and_another_tool_contradict_each_other():
    from franka_sim.cli import _tool

    assert _tool("hand", True) == "none" and _tool("none", True) == "none"
    assert _tool("hand", False) == "hand"


def test_each_arm_may_carry_its_own_tool():
    """`--arm left+vacuum=A --arm right=B`: left's pump answers on A:1339 (its Hand's port
    refuses), right carries --tool's Hand on B:1338 (its pump's port refuses); each tool's
    physical part is on its own arm."""
    from franka_sim.control import Control
    from franka_sim.testing import fresh_loopback_address

    left, right = fresh_loopback_address(), fresh_loopback_address()
    with running_sim("--arm", f"left+vacuum={left}", "--arm", f"right={right}",
                     "--scene", "dual_arm_table", "--clock", "lockstep", host=left):
        for host, serving, refusing in ((left, 1339, 1338), (right, 1338, 1339)):
            socket.create_connection((host, serving), timeout=5).close()
            with pytest.raises(ConnectionRefusedError):
                socket.create_connection((host, refusing), timeout=5).close()
        assert Control(left).state()["vacuum_gripper"]["vacuum"] == 0.0
        assert Control(left).state()["gripper_width"] is None
        assert Control(right).state()["vacuum_gripper"] is None
        assert Control(right).state()["gripper_width"] > 0.07


def test_the_desks_gripper_homing_on_an_arm_with_the_pump_is_refused_in_one_line(tmp_path):
    """A Panda's Desk (system 4) asked to home the gripper while the arm carries the vacuum
    gripper: 409 saying so, one log line, and the pump and the Desk serve on."""
    import json
    import ssl
    import urllib.request

    from franka_sim.desk.users import browser_password

    def call(host, path, body=None, headers=None, cookie=None):
        request = urllib.request.Request(
            f"https://{host}:8443{path}", method="POST",
            data=json.dumps(body).encode() if body is not None else None,
            headers={"Content-Type": "application/json",
                     **({"Cookie": f"authorization={cookie}"} if cookie else {}),
                     **(headers or {})})
        with urllib.request.urlopen(request, context=ssl._create_unverified_context(),
                                    timeout=30) as answer:
            text = answer.read().decode()
        return json.loads(text) if text.startswith("{") else text

    with running_sim("--clock", "lockstep", "--robot", "fer", "--tool", "vacuum",
                     "--desk-port", "8443", "--desk-boot", "locked", "--desk-user",
                     "admin:secret", env={"XDG_DATA_HOME": str(tmp_path)}) as sim:
        session = call(sim.host, "/admin/api/login",
                       {"login": "admin", "password": browser_password("admin", "secret")})
        token = call(sim.host, "/admin/api/control-token/request", {"requestedBy": "admin"},
                     cookie=session)
        with pytest.raises(urllib.error.HTTPError) as refused:
            call(sim.host, "/desk/api/gripper/homing",
                 headers={"X-Control-Token": token["token"]}, cookie=session)
        assert refused.value.code == 409
        assert "no Franka Hand on this arm" in json.loads(refused.value.read())["error"]
        assert len(sim.wait_for_log("refused (409 Conflict): no Franka Hand on this arm")) == 1
        socket.create_connection((sim.host, 1339), timeout=5).close()
