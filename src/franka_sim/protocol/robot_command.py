"""RobotCommand: the 371-byte UDP datagram a client sends in answer to each RobotState.

The FCI groups these fields into a motion part (q_c ... motion_generation_finished) and a control
part (tau_J_d, torque_command_finished); on the wire that grouping adds no bytes, so we declare
them flat. Unlike the state, every number here is float64. The client fills only the part that
matches the running mode and leaves the rest zero.
"""

from construct import Array, Flag, Float64l, Int64ul, Struct


def _f64(n: int) -> Array:
    return Array(n, Float64l)


RobotCommand = Struct(
    "message_id" / Int64ul,  # id of the latest state the client had processed
    "q_c" / _f64(7),
    "dq_c" / _f64(7),
    "O_T_EE_c" / _f64(16),  # column-major 4x4
    "O_dP_EE_c" / _f64(6),
    "elbow_c" / _f64(2),
    "valid_elbow" / Flag,
    "motion_generation_finished" / Flag,
    "tau_J_d" / _f64(7),
    "torque_command_finished" / Flag,
)

ROBOT_COMMAND_SIZE = 371
assert RobotCommand.sizeof() == ROBOT_COMMAND_SIZE, RobotCommand.sizeof()
