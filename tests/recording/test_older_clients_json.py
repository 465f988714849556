"""A recording's readable view of an older robot client's conversation (recording/wire_json.py,
no server): after a Connect of version 5–9 its requests read by that version's tables and the
replies named and statused as that version wrote them, not misread by v10's (libfranka
0.9.2's SetCollisionBehavior was "malformed" there, 0.13's LoadModelLibrary reply a
GetRobotModel)."""

from __future__ import annotations

import pytest

from franka_sim.protocol import enums as v10
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import robot_v5 as v5
from franka_sim.protocol import robot_v6 as v6
from franka_sim.protocol import robot_v7 as v7
from franka_sim.protocol import robot_v9 as v9
from franka_sim.protocol.message import build_message
from franka_sim.recording.wire_json import RequestDecoder, decode_reply

COLLISION = {name: [20.0] * (7 if "torque" in name else 6) for name in (
    f"{side}_{kind}_thresholds_{phase}" for side in ("lower", "upper")
    for kind in ("torque", "force") for phase in ("acceleration", "nominal"))}


def _request(module, command: str, command_id: int, **fields) -> bytes:
    enum = module.Command[command]
    return build_message(module.REQUEST_STRUCTS[enum], enum, command_id, fields)


def _connected(module) -> RequestDecoder:
    decoder = RequestDecoder("robot")
    (connect,) = decoder.feed(_request(module, "Connect", 0, version=module.VERSION,
                                       udp_port=4242))
    assert connect["version"] == module.VERSION
    assert isinstance(decoder.dialect, module.Dialect)
    return decoder


@pytest.mark.parametrize("module", [v5, v6, v7, v9])
def test_an_older_clients_requests_read_by_its_tables(module):
    decoder = _connected(module)
    (request,) = decoder.feed(_request(module, "SetCollisionBehavior", 1, **COLLISION))
    assert request["command"] == "SetCollisionBehavior"
    assert request["upper_force_thresholds_nominal"] == [20.0] * 6
    (request,) = decoder.feed(_request(module, "LoadModelLibrary", 2, architecture="kX64",
                                       system="kLinux"))
    assert request == {"command": "LoadModelLibrary", "command_id": 2,
                       "architecture": "kX64", "system": "kLinux"}


def test_a_v10_client_keeps_v10s_tables():
    decoder = RequestDecoder("robot")
    decoder.feed(build_message(rm.REQUEST_STRUCTS[v10.Command.Connect], v10.Command.Connect,
                               0, {"version": 10, "udp_port": 4242}))
    assert decoder.dialect is None
    (request,) = decoder.feed(build_message(
        rm.REQUEST_STRUCTS[v10.Command.SetCollisionBehavior], v10.Command.SetCollisionBehavior,
        1, COLLISION))
    assert request["command"] == "SetCollisionBehavior"


@pytest.mark.parametrize("module, older_of", [
    (v5, {v10.Command.Move: v5.MoveStatus, v10.Command.StopMove: v5.StopMoveStatus,
          v10.Command.AutomaticErrorRecovery: v5.AutomaticErrorRecoveryStatus,
          v10.Command.SetCollisionBehavior: v5.GetterSetterStatus}),
    (v6, {v10.Command.Move: v10.MoveStatus, v10.Command.StopMove: v10.StopMoveStatus,
          v10.Command.AutomaticErrorRecovery: v10.AutomaticErrorRecoveryStatus,
          v10.Command.SetCollisionBehavior: v10.GetterSetterStatus})])
@pytest.mark.parametrize("command, statuses", [
    (v10.Command.Move, v10.MoveStatus), (v10.Command.StopMove, v10.StopMoveStatus),
    (v10.Command.AutomaticErrorRecovery, v10.AutomaticErrorRecoveryStatus),
    (v10.Command.SetCollisionBehavior, v10.GetterSetterStatus)])
def test_a_reply_reads_with_the_status_the_client_read(module, older_of, command, statuses):
    """Every status, written as v5 or v6 numbers it, reads back as the name the client got
    (the nearest v5 has, for the safety statuses it lacks; v6 has v10's)."""
    dialect = module.Dialect()
    older = older_of[command]
    for status in statuses:
        wire = dialect.reply(rm.build_response(command, 7, status))
        read = decode_reply("robot", wire, dialect)
        assert read["command"] == command.name and read["command_id"] == 7
        assert read["status"] == older(wire[12]).name


def test_a_load_model_library_reply_is_named_as_such():
    dialect = v7.Dialect()
    wire = dialect.answer(v7.Command.LoadModelLibrary, 3, None, lambda request: b"\x7fELF...")
    assert decode_reply("robot", wire, dialect) == {
        "command": "LoadModelLibrary", "command_id": 3, "status": "kSuccess",
        "library": "<7 bytes>"}
    assert decode_reply("robot", wire)["command"] == "GetRobotModel"  # what v10 would say


def test_v5s_own_replies_are_read():
    dialect = v5.Dialect()
    wire = dialect.answer(v5.Command.GetCartesianLimit, 4, None, None)
    read = decode_reply("robot", wire, dialect)
    assert read["command"] == "GetCartesianLimit" and read["status"] == "kSuccess"
    assert read["object_activation"] is False
