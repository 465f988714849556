"""Robot TCP messages (port 1337, protocol v10): one request and one response per command.

Every message is ``CommandHeader`` + payload. Responses echo the request's command_id (the only
thing the client matches on) and start their payload with a one-byte status whose meaning
depends on the command, hence one status enum per response.
"""

from typing import Any

from construct import Array, Enum, Flag, Float64l, GreedyBytes, Int8ul, Int16ul, Int32ul, Struct

from .enums import (
    AutomaticErrorRecoveryStatus,
    BaseStatus,
    Command,
    ConnectStatus,
    GetterSetterStatus,
    MoveControllerMode,
    MoveMotionGeneratorMode,
    MoveStatus,
    StopMoveStatus,
)
from .message import build_message, command_header, message

CommandHeader = command_header(Command)
COMMAND_HEADER_SIZE = 12
assert CommandHeader.sizeof() == COMMAND_HEADER_SIZE


def _f64(n: int) -> Array:
    return Array(n, Float64l)


# Tolerances the robot may allow between commanded and actual motion; libfranka always sends
# its defaults, but a simulator may still want to read them.
Deviation = Struct("translation" / Float64l, "rotation" / Float64l, "elbow" / Float64l)

# --- requests -------------------------------------------------------------------------------

ConnectRequest = message(CommandHeader, "version" / Int16ul, "udp_port" / Int16ul)
MoveRequest = message(
    CommandHeader,
    "controller_mode" / Enum(Int32ul, MoveControllerMode),
    "motion_generator_mode" / Enum(Int32ul, MoveMotionGeneratorMode),
    "maximum_path_deviation" / Deviation,
    "maximum_goal_pose_deviation" / Deviation,
    "use_async_motion_generator" / Flag,
    "maximum_velocity" / _f64(7),  # only meaningful for the async generator
)
StopMoveRequest = message(CommandHeader)
SetCollisionBehaviorRequest = message(
    CommandHeader,
    "lower_torque_thresholds_acceleration" / _f64(7),
    "upper_torque_thresholds_acceleration" / _f64(7),
    "lower_torque_thresholds_nominal" / _f64(7),
    "upper_torque_thresholds_nominal" / _f64(7),
    "lower_force_thresholds_acceleration" / _f64(6),
    "upper_force_thresholds_acceleration" / _f64(6),
    "lower_force_thresholds_nominal" / _f64(6),
    "upper_force_thresholds_nominal" / _f64(6),
)
SetJointImpedanceRequest = message(CommandHeader, "K_theta" / _f64(7))
SetCartesianImpedanceRequest = message(CommandHeader, "K_x" / _f64(6))
SetGuidingModeRequest = message(
    CommandHeader,
    "guiding_mode" / Array(6, Flag),  # x, y, z, roll, pitch, yaw
    "nullspace" / Flag,  # libfranka's API calls this `elbow`
)
SetEEToKRequest = message(CommandHeader, "EE_T_K" / _f64(16))  # column-major
SetNEToEERequest = message(CommandHeader, "NE_T_EE" / _f64(16))  # column-major
SetLoadRequest = message(
    CommandHeader, "m_load" / Float64l, "F_x_Cload" / _f64(3), "I_load" / _f64(9)
)
AutomaticErrorRecoveryRequest = message(CommandHeader)
GetRobotModelRequest = message(CommandHeader)

# --- responses ------------------------------------------------------------------------------


def _status_response(status_enum: type) -> Struct:
    return message(CommandHeader, "status" / Enum(Int8ul, status_enum))


ConnectResponse = message(
    CommandHeader,
    "status" / Enum(Int8ul, ConnectStatus),
    "version" / Int16ul,  # the server's version, stored by the client without comparing
)
MoveResponse = _status_response(MoveStatus)
StopMoveResponse = _status_response(StopMoveStatus)
SetCollisionBehaviorResponse = _status_response(GetterSetterStatus)
SetJointImpedanceResponse = _status_response(GetterSetterStatus)
SetCartesianImpedanceResponse = _status_response(GetterSetterStatus)
SetGuidingModeResponse = _status_response(GetterSetterStatus)
SetEEToKResponse = _status_response(GetterSetterStatus)
SetNEToEEResponse = _status_response(GetterSetterStatus)
SetLoadResponse = _status_response(GetterSetterStatus)
AutomaticErrorRecoveryResponse = _status_response(AutomaticErrorRecoveryStatus)
GetRobotModelResponse = message(
    CommandHeader,
    "status" / Enum(Int8ul, BaseStatus),
    "urdf" / GreedyBytes,  # no length prefix: the header size delimits it
)

REQUEST_STRUCTS: dict[Command, Struct] = {
    Command.Connect: ConnectRequest,
    Command.Move: MoveRequest,
    Command.StopMove: StopMoveRequest,
    Command.SetCollisionBehavior: SetCollisionBehaviorRequest,
    Command.SetJointImpedance: SetJointImpedanceRequest,
    Command.SetCartesianImpedance: SetCartesianImpedanceRequest,
    Command.SetGuidingMode: SetGuidingModeRequest,
    Command.SetEEToK: SetEEToKRequest,
    Command.SetNEToEE: SetNEToEERequest,
    Command.SetLoad: SetLoadRequest,
    Command.AutomaticErrorRecovery: AutomaticErrorRecoveryRequest,
    Command.GetRobotModel: GetRobotModelRequest,
}

RESPONSE_STRUCTS: dict[Command, Struct] = {
    Command.Connect: ConnectResponse,
    Command.Move: MoveResponse,
    Command.StopMove: StopMoveResponse,
    Command.SetCollisionBehavior: SetCollisionBehaviorResponse,
    Command.SetJointImpedance: SetJointImpedanceResponse,
    Command.SetCartesianImpedance: SetCartesianImpedanceResponse,
    Command.SetGuidingMode: SetGuidingModeResponse,
    Command.SetEEToK: SetEEToKResponse,
    Command.SetNEToEE: SetNEToEEResponse,
    Command.SetLoad: SetLoadResponse,
    Command.AutomaticErrorRecovery: AutomaticErrorRecoveryResponse,
    Command.GetRobotModel: GetRobotModelResponse,
}

# Every v10 request has a fixed size, so the frame reader can reject a bad header before
# waiting for its payload.
REQUEST_SIZES: dict[Command, int] = {cmd: s.sizeof() for cmd, s in REQUEST_STRUCTS.items()}


def build_request(command: Command, command_id: int, **fields: Any) -> bytes:
    """Bytes of a request as a client sends it (for tests and Python clients)."""
    return build_message(REQUEST_STRUCTS[Command(command)], command, command_id, fields)


def build_response(command: Command, command_id: int, status: int, **extra: Any) -> bytes:
    """Bytes of the response to ``command``; header.size is filled in.

    ``status`` may be an int or an FCI name ("kMotionStarted"). Extra fields: ``version`` for
    Connect, ``urdf: bytes`` for GetRobotModel.
    """
    struct = RESPONSE_STRUCTS[Command(command)]
    return build_message(struct, command, command_id, {"status": status, **extra})
