"""The construct declarations match the v10 / v3 wire layout, field by field."""

import math

import pytest
from construct import Container

from franka_sim.protocol import (
    ERROR_NAMES,
    GRIPPER_REQUEST_SIZES,
    GRIPPER_REQUEST_STRUCTS,
    GRIPPER_RESPONSE_STRUCTS,
    NUM_ERRORS,
    REQUEST_SIZES,
    REQUEST_STRUCTS,
    RESPONSE_STRUCTS,
    STATE_MOTION_GENERATOR_MODE,
    Command,
    CommandHeader,
    ConnectResponse,
    GetRobotModelResponse,
    GripperCommand,
    GripperHeader,
    GripperState,
    MotionGeneratorMode,
    MoveMotionGeneratorMode,
    MoveRequest,
    MoveResponse,
    RobotCommand,
    RobotState,
    build_gripper_response,
    build_request,
    build_response,
    error_index,
    errors_to_names,
)

# protocol_specs/robot_v10.md "RobotState", restated: (offset, field, element count, element size)
ROBOT_STATE_OFFSETS = [
    (0, "message_id", 1, 8), (8, "O_T_EE", 16, 4), (72, "O_T_EE_d", 16, 4),
    (136, "F_T_EE", 16, 4), (200, "EE_T_K", 16, 4), (264, "F_T_NE", 16, 4),
    (328, "NE_T_EE", 16, 4), (392, "m_ee", 1, 4), (396, "I_ee", 9, 4), (432, "F_x_Cee", 3, 4),
    (444, "m_load", 1, 4), (448, "I_load", 9, 4), (484, "F_x_Cload", 3, 4),
    (496, "elbow", 2, 4), (504, "elbow_d", 2, 4), (512, "tau_J", 7, 4), (540, "tau_J_d", 7, 4),
    (568, "dtau_J", 7, 4), (596, "q", 7, 4), (624, "q_d", 7, 4), (652, "dq", 7, 4),
    (680, "dq_d", 7, 4), (708, "ddq_d", 7, 4), (736, "joint_contact", 7, 4),
    (764, "cartesian_contact", 6, 4), (788, "joint_collision", 7, 4),
    (816, "cartesian_collision", 6, 4), (840, "tau_ext_hat_filtered", 7, 4),
    (868, "O_F_ext_hat_K", 6, 4), (892, "K_F_ext_hat_K", 6, 4), (916, "O_dP_EE_d", 6, 4),
    (940, "O_ddP_O", 3, 4), (952, "elbow_c", 2, 4), (960, "delbow_c", 2, 4),
    (968, "ddelbow_c", 2, 4), (976, "O_T_EE_c", 16, 4), (1040, "O_dP_EE_c", 6, 4),
    (1064, "O_ddP_EE_c", 6, 4), (1088, "theta", 7, 4), (1116, "dtheta", 7, 4),
    (1144, "accelerometer_top", 18, 4), (1216, "accelerometer_bottom", 18, 4),
    (1288, "motion_generator_mode", 1, 1), (1289, "controller_mode", 1, 1),
    (1290, "errors", 41, 1), (1331, "reflex_reason", 41, 1), (1372, "robot_mode", 1, 1),
    (1373, "control_command_success_rate", 1, 4),
]

# protocol_specs/robot_v10.md, "RobotCommand"
ROBOT_COMMAND_OFFSETS = [
    (0, "message_id", 1, 8), (8, "q_c", 7, 8), (64, "dq_c", 7, 8), (120, "O_T_EE_c", 16, 8),
    (248, "O_dP_EE_c", 6, 8), (296, "elbow_c", 2, 8), (312, "valid_elbow", 1, 1),
    (313, "motion_generation_finished", 1, 1), (314, "tau_J_d", 7, 8),
    (370, "torque_command_finished", 1, 1),
]


def layout_of(struct):
    """(offset, name, size) of each top-level field, as construct lays it out."""
    offset, rows = 0, []
    for sub in struct.subcons:
        rows.append((offset, sub.name, sub.sizeof()))
        offset += sub.sizeof()
    return rows


@pytest.mark.parametrize(
    "struct, table, total",
    [(RobotState, ROBOT_STATE_OFFSETS, 1377), (RobotCommand, ROBOT_COMMAND_OFFSETS, 371)],
    ids=["RobotState", "RobotCommand"],
)
def test_every_field_sits_at_its_documented_offset(struct, table, total):
    expected = [(off, name, count * size) for off, name, count, size in table]
    assert layout_of(struct) == expected
    assert struct.sizeof() == total == table[-1][0] + table[-1][2] * table[-1][3]


def test_headers_are_12_and_10_bytes():
    assert CommandHeader.sizeof() == 12
    assert GripperHeader.sizeof() == 10
    assert GripperState.sizeof() == 23


def test_request_sizes_are_the_documented_fixed_sizes():
    documented = {
        Command.Connect: 16, Command.Move: 125, Command.StopMove: 12,
        Command.SetCollisionBehavior: 428, Command.SetJointImpedance: 68,
        Command.SetCartesianImpedance: 60, Command.SetGuidingMode: 19, Command.SetEEToK: 140,
        Command.SetNEToEE: 140, Command.SetLoad: 116, Command.AutomaticErrorRecovery: 12,
        Command.GetRobotModel: 12,
    }
    assert REQUEST_SIZES == documented
    assert set(REQUEST_STRUCTS) == set(RESPONSE_STRUCTS) == set(Command)
    assert GRIPPER_REQUEST_SIZES == {
        GripperCommand.Connect: 14, GripperCommand.Homing: 10, GripperCommand.Grasp: 50,
        GripperCommand.Move: 26, GripperCommand.Stop: 10,
    }
    assert set(GRIPPER_REQUEST_STRUCTS) == set(GRIPPER_RESPONSE_STRUCTS) == set(GripperCommand)


def test_response_sizes():
    for command, struct in RESPONSE_STRUCTS.items():
        if command is Command.GetRobotModel:
            continue  # variable: the URDF runs to the end
        assert struct.sizeof() == (15 if command is Command.Connect else 13), command
    for command, struct in GRIPPER_RESPONSE_STRUCTS.items():
        assert struct.sizeof() == (14 if command is GripperCommand.Connect else 12), command


def test_build_response_fills_in_the_total_size():
    data = build_response(Command.GetRobotModel, 1, 0, urdf=b"<robot/>")
    message = GetRobotModelResponse.parse(data)
    assert message.header.size == len(data) == 13 + 8
    assert message.header.command_id == 1 and message.urdf == b"<robot/>"
    connect = ConnectResponse.parse(build_response(Command.Connect, 0, "kSuccess", version=10))
    assert (connect.header.size, connect.status, connect.version) == (15, "kSuccess", 10)
    grip = build_gripper_response(GripperCommand.Connect, 7, 1, version=3)
    assert GRIPPER_RESPONSE_STRUCTS[GripperCommand.Connect].parse(grip).header.size == 14
    assert len(build_gripper_response(GripperCommand.Grasp, 8, "kUnsuccessful")) == 12


def test_move_request_round_trips_with_enum_names():
    deviation = {"translation": 10.0, "rotation": 3.12, "elbow": 2 * math.pi}
    data = build_request(
        Command.Move, 2, controller_mode="kExternalController", motion_generator_mode=4,
        maximum_path_deviation=deviation, maximum_goal_pose_deviation=deviation,
        use_async_motion_generator=False, maximum_velocity=[0.0] * 7,
    )
    assert len(data) == 125
    move = MoveRequest.parse(data)
    assert move.header == Container(command="Move", command_id=2, size=125)
    assert move.controller_mode == "kExternalController"
    assert move.motion_generator_mode == "kNone" and int(move.motion_generator_mode) == 4
    assert move.maximum_path_deviation.elbow == 2 * math.pi


def test_decoded_state_reads_like_the_spec():
    values = dict(RobotState.parse(bytes(1377)))
    values |= {"motion_generator_mode": 1, "controller_mode": 2, "robot_mode": 4}
    state = RobotState.parse(RobotState.build(values))
    assert state.motion_generator_mode == "kJointPosition"
    assert state.controller_mode == "kExternalController"
    assert state.robot_mode == "kReflex"
    assert state.errors == [False] * NUM_ERRORS


def test_unknown_status_values_still_decode():
    # The client treats unlisted statuses as protocol errors; we must be able to send them.
    assert int(MoveResponse.parse(build_response(Command.Move, 3, 200)).status) == 200


def test_move_modes_map_to_the_shifted_state_modes():
    for move_mode in MoveMotionGeneratorMode:
        assert STATE_MOTION_GENERATOR_MODE[move_mode] == move_mode + 1
        assert STATE_MOTION_GENERATOR_MODE[move_mode].name == move_mode.name
    assert MotionGeneratorMode(0).name == "kIdle"


def test_error_table():
    assert NUM_ERRORS == len(ERROR_NAMES) == 41
    assert ERROR_NAMES[0] == "joint_position_limits_violation"
    assert ERROR_NAMES[25] == "communication_constraints_violation"
    assert error_index("cartesian_position_motion_generator_invalid_frame") == 31
    assert error_index("tau_J_range_violation") == 34
    assert error_index("base_acceleration_invalid_reading") == 40
    with pytest.raises(KeyError):
        error_index("no_such_error")


def test_errors_to_names_lists_set_bits_in_order():
    bits = [False] * 41
    bits[34] = bits[6] = True
    assert errors_to_names(bits) == ["joint_reflex", "tau_J_range_violation"]
    assert errors_to_names(RobotState.parse(bytes(1377)).reflex_reason) == []
    with pytest.raises(ValueError):
        errors_to_names([True] * 40)
