"""Version-5 and version-6 clients' conversations, sans-IO (libfranka 0.9 and 0.10–0.12;
protocol_specs/robot_v5.md): their ids read as v10's, replies written with their ids and (v5)
their statuses by name, v5's GetCartesianLimit and SetFilters answered by the dialect, their
370-byte RobotCommand read as v10's with torque_command_finished false."""

from __future__ import annotations

import logging
import struct

import numpy as np
import pytest

from franka_sim.protocol import enums as v10
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import robot_v5 as v5
from franka_sim.protocol import robot_v6 as v6
from franka_sim.protocol import robot_v9 as v9
from franka_sim.protocol.codec import decode_command, encode_command
from franka_sim.protocol.message import build_message
from franka_sim.robot.session import ROBOT, Session, SessionError


class _Robot:
    """Records what the session hands on and answers with the status it is told to."""

    def __init__(self) -> None:
        self.requests = []
        self.status = 0

    def handle(self, command, command_id, request):
        self.requests.append((command, request))
        return [rm.build_response(command, command_id, self.status)]


def _request(module, command, command_id: int, **fields) -> bytes:
    return build_message(module.REQUEST_STRUCTS[command], command, command_id, fields)


def _connected(module, library=None) -> tuple[Session, _Robot]:
    robot = _Robot()
    session = Session(ROBOT, robot.handle, library)
    (reply,) = session.feed(_request(module, module.Command.Connect, 0,
                                     version=module.VERSION, udp_port=4242))
    assert struct.unpack_from("<IIIBH", reply) == (0, 0, 15, 0, module.VERSION)  # kSuccess
    assert isinstance(session.dialect, module.Dialect)
    return session, robot


COLLISION = {"lower_torque_thresholds_acceleration": [20.0] * 7,
             "upper_torque_thresholds_acceleration": [20.0] * 7,
             "lower_torque_thresholds_nominal": [20.0] * 7,
             "upper_torque_thresholds_nominal": [20.0] * 7,
             "lower_force_thresholds_acceleration": [20.0] * 6,
             "upper_force_thresholds_acceleration": [20.0] * 6,
             "lower_force_thresholds_nominal": [20.0] * 6,
             "upper_force_thresholds_nominal": [20.0] * 6}


@pytest.mark.parametrize("module, wire_id", [(v5, 4), (v6, 3)])
def test_a_shifted_id_reads_as_v10s_and_its_reply_goes_back_under_it(module, wire_id):
    session, robot = _connected(module)
    assert int(module.Command.SetCollisionBehavior) == wire_id
    (reply,) = session.feed(_request(module, module.Command.SetCollisionBehavior, 9,
                                     **COLLISION))
    assert robot.requests[-1][0] is v10.Command.SetCollisionBehavior
    assert struct.unpack_from("<IIIB", reply) == (wire_id, 9, 13, 0)


@pytest.mark.parametrize("torn", [0, 7])
def test_requests_that_come_with_the_connect_are_cut_by_the_clients_version(torn):
    """A v5 Connect and a v5 SetLoad in one read (v10's id 10 is a 12-byte recovery, v5's a
    SetLoad of 12 + 136 bytes): the SetLoad is read as v5's, whole or torn after `torn` more
    bytes, not cut by v10's sizes."""
    robot = _Robot()
    session = Session(ROBOT, robot.handle, None)
    connect = _request(v5, v5.Command.Connect, 0, version=v5.VERSION, udp_port=4242)
    load = _request(v5, v5.Command.SetLoad, 1, m_load=0.5, F_x_Cload=[0.0, 0.0, 0.05],
                    I_load=[0.001, 0, 0, 0, 0.001, 0, 0, 0, 0.001])
    cut = len(load) - torn
    replies = session.feed(connect + load[:cut]) + session.feed(load[cut:])
    assert len(replies) == 2 and not session.closed
    assert robot.requests[-1][0] is v10.Command.SetLoad
    assert robot.requests[-1][1].m_load == 0.5
    assert struct.unpack_from("<IIIB", replies[1]) == (int(v5.Command.SetLoad), 1, 13, 0)


def test_a_status_v5_has_no_name_for_is_the_nearest_it_has():
    """v10's safety statuses came after v5: rejected by a safety function reads as not
    possible, preempted by one as preempted."""
    module = v5
    session, robot = _connected(module)
    robot.status = v10.GetterSetterStatus.kCommandRejectedDueToActivatedSafetyFunctions
    (reply,) = session.feed(_request(module, module.Command.SetCollisionBehavior, 1,
                                     **COLLISION))
    assert reply[12] == v5.GetterSetterStatus.kCommandNotPossibleRejected
    robot.status = v10.AutomaticErrorRecoveryStatus.kManualErrorRecoveryRequiredRejected
    (reply,) = session.feed(_request(module, module.Command.AutomaticErrorRecovery, 2))
    assert reply[12] == v5.AutomaticErrorRecoveryStatus.kManualErrorRecoveryRequiredRejected == 2
    final = rm.build_response(v10.Command.Move, 3,
                              v10.MoveStatus.kPreemptedDueToActivatedSafetyFunctions)
    assert session.wire(final)[12] == v5.MoveStatus.kPreempted
    assert struct.unpack_from("<I", session.wire(final))[0] == 1


@pytest.mark.parametrize("older, newer", [
    (v5.MoveStatus, v10.MoveStatus), (v5.StopMoveStatus, v10.StopMoveStatus),
    (v5.AutomaticErrorRecoveryStatus, v10.AutomaticErrorRecoveryStatus),
    (v5.GetterSetterStatus, v10.GetterSetterStatus)])
def test_every_v10_status_has_a_v5_value_and_shared_names_keep_theirs(older, newer):
    table = v5._by_name(older, newer, {**v5._SAFETY,
                                        "kPreemptedDueToActivatedSafetyFunctions": "kPreempted"})
    assert set(table) == {int(s) for s in newer}
    for status in newer:
        if status.name in older.__members__:
            assert table[int(status)] == int(older[status.name])


def test_v5s_get_cartesian_limit_is_answered_without_a_virtual_wall():
    session, robot = _connected(v5)
    (reply,) = session.feed(_request(v5, v5.Command.GetCartesianLimit, 4, id=0))
    assert robot.requests == []  # the dialect answers it
    parsed = v5.GetCartesianLimitResponse.parse(reply)
    assert (int(parsed.header.command), parsed.header.command_id) == (3, 4)
    assert parsed.status == "kSuccess" and parsed.object_activation is False
    assert np.array_equal(np.reshape(parsed.object_frame, (4, 4)), np.eye(4))


def test_v6_has_neither_get_cartesian_limit_nor_set_filters():
    """libfranka 0.10.0 to 0.12.1 (their `common` at the tag) number AutomaticErrorRecovery 10
    and LoadModelLibrary 11, as v7: an id past 11 is no command of theirs."""
    session, robot = _connected(v6)
    assert {"GetCartesianLimit", "SetFilters"}.isdisjoint(v6.Command.__members__)
    assert (int(v6.Command.AutomaticErrorRecovery), int(v6.Command.LoadModelLibrary)) == (10, 11)
    with pytest.raises(SessionError, match="unknown command 12"):
        session.feed(struct.pack("<III", 12, 4, 12))


def test_v6_writes_the_safety_statuses_as_v10_numbers_them():
    """v6 has kCommandRejectedDueToActivatedSafetyFunctions and Move's
    kPreemptedDueToActivatedSafetyFunctions, at v10's values: nothing is renumbered."""
    session, robot = _connected(v6)
    robot.status = v10.GetterSetterStatus.kCommandRejectedDueToActivatedSafetyFunctions
    (reply,) = session.feed(_request(v6, v6.Command.SetCollisionBehavior, 1, **COLLISION))
    assert reply[12] == v10.GetterSetterStatus.kCommandRejectedDueToActivatedSafetyFunctions == 3
    robot.status = v10.AutomaticErrorRecoveryStatus.kReflexAborted
    (reply,) = session.feed(_request(v6, v6.Command.AutomaticErrorRecovery, 2))
    assert struct.unpack_from("<IIIB", reply) == (
        10, 2, 13, v10.AutomaticErrorRecoveryStatus.kReflexAborted)
    final = rm.build_response(v10.Command.Move, 3,
                              v10.MoveStatus.kPreemptedDueToActivatedSafetyFunctions)
    assert session.wire(final)[12] == v10.MoveStatus.kPreemptedDueToActivatedSafetyFunctions
    assert v10.MoveStatus.kPreemptedDueToActivatedSafetyFunctions != v5.MoveStatus.kPreempted


def test_set_filters_is_taken_and_logged(caplog):
    module = v5
    session, robot = _connected(module)
    with caplog.at_level(logging.INFO):
        (reply,) = session.feed(_request(module, module.Command.SetFilters, 5, **{
            f.name: 100.0 for f in v5.SetFiltersRequest.subcons[1:]}))
    assert robot.requests == []
    assert struct.unpack_from("<IIIB", reply) == (int(module.Command.SetFilters), 5, 13, 0)
    assert "SetFilters taken" in caplog.text


@pytest.mark.parametrize("module, wire_id", [(v5, 13), (v6, 11)])
def test_load_model_library_has_its_versions_id(module, wire_id):
    session, _ = _connected(module, library=lambda request: b"\x7fELF")
    (reply,) = session.feed(_request(module, module.Command.LoadModelLibrary, 6,
                                     architecture="kX64", system="kLinux"))
    assert struct.unpack_from("<I", reply)[0] == wire_id
    parsed = v9.LoadModelLibraryResponse.parse(reply)  # v9's layout under this id
    assert parsed.status == "kSuccess" and parsed.library == b"\x7fELF"


@pytest.mark.parametrize("module", [v5, v6])
def test_a_370_byte_command_reads_as_v10s_with_torque_command_finished_false(module):
    """Torque control in v5 and v6 ends with motion_generation_finished; the byte v10 added
    is read as false."""
    fields = {"message_id": 77, "q_c": np.arange(7.0), "dq_c": np.zeros(7),
              "O_T_EE_c": np.eye(4).ravel(order="F"), "O_dP_EE_c": np.ones(6),
              "elbow_c": [0.5, -1.0], "valid_elbow": True, "motion_generation_finished": True,
              "tau_J_d": np.linspace(-1, 1, 7), "torque_command_finished": True}
    v10_bytes = encode_command(**fields)
    older = v10_bytes[:v5.ROBOT_COMMAND_SIZE]  # the v5 layout is v10's without the last byte
    read = decode_command(module.Dialect().command(older))
    assert read["torque_command_finished"] == False  # noqa: E712 - a numpy bool
    for name in ("message_id", "q_c", "O_dP_EE_c", "elbow_c", "motion_generation_finished",
                 "tau_J_d"):
        assert np.array_equal(read[name], fields[name]), name
    assert module.Dialect().command(v10_bytes[:200]) == v10_bytes[:200]  # for the endpoint


@pytest.mark.parametrize("kind, refused, own", [("fer", 10, 5), ("fr3", 5, 10)])
def test_a_pairing_refuses_the_versions_its_robot_does_not_speak(kind, refused, own):
    """--strict-versions: the robot's incompatible-version reply names its own version, and
    the session closes."""
    from franka_sim.robot.session import PAIRINGS

    session = Session(ROBOT, _Robot().handle, None, PAIRINGS[kind], strict=True)
    (reply,) = session.feed(_request(v5, v5.Command.Connect, 0, version=refused,
                                     udp_port=4242))
    assert struct.unpack_from("<IIIBH", reply) == (0, 0, 15, 1, own)
    assert session.closed and session.handshake is None


@pytest.mark.parametrize("kind, own", [("fer", 5), ("fr3", 10)])
def test_a_version_nobody_serves_is_refused_with_the_robots_own(kind, own):
    """libfranka 0.8 (protocol 4) at a Panda, strict or not: the reply names 5, the
    libfranka to use with this robot, not the newest the simulator serves."""
    from franka_sim.robot.session import PAIRINGS

    session = Session(ROBOT, _Robot().handle, None, PAIRINGS[kind])
    (reply,) = session.feed(_request(v5, v5.Command.Connect, 0, version=4, udp_port=4242))
    assert struct.unpack_from("<IIIBH", reply) == (0, 0, 15, 1, own)
    assert session.closed
