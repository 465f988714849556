"""RobotState: the 1377-byte UDP datagram the robot publishes once per 1 ms cycle.

This declaration is the single source of truth for the layout; the hot-path codec
(:mod:`franka_sim.protocol.codec`) derives its numpy dtype from it. Every array is float32 on the
wire since protocol v10 (the client widens to double), matrices are 4x4 column-major flattened to
16 values, and the two accelerometer arrays are 6 sensors x (x, y, z), sensor-major.
"""

from construct import Array, Enum, Flag, Float32l, Int8ul, Int64ul, Struct

from .enums import ControllerMode, MotionGeneratorMode, RobotMode
from .errors import NUM_ERRORS


def _f32(n: int) -> Array:
    return Array(n, Float32l)


RobotState = Struct(
    "message_id" / Int64ul,  # cycle counter; the client reads it as milliseconds
    "O_T_EE" / _f32(16),
    "O_T_EE_d" / _f32(16),
    "F_T_EE" / _f32(16),
    "EE_T_K" / _f32(16),
    "F_T_NE" / _f32(16),
    "NE_T_EE" / _f32(16),
    "m_ee" / Float32l,
    "I_ee" / _f32(9),
    "F_x_Cee" / _f32(3),
    "m_load" / Float32l,
    "I_load" / _f32(9),
    "F_x_Cload" / _f32(3),
    "elbow" / _f32(2),
    "elbow_d" / _f32(2),
    "tau_J" / _f32(7),
    "tau_J_d" / _f32(7),
    "dtau_J" / _f32(7),
    "q" / _f32(7),
    "q_d" / _f32(7),
    "dq" / _f32(7),
    "dq_d" / _f32(7),
    "ddq_d" / _f32(7),
    "joint_contact" / _f32(7),
    "cartesian_contact" / _f32(6),
    "joint_collision" / _f32(7),
    "cartesian_collision" / _f32(6),
    "tau_ext_hat_filtered" / _f32(7),
    "O_F_ext_hat_K" / _f32(6),
    "K_F_ext_hat_K" / _f32(6),
    "O_dP_EE_d" / _f32(6),
    "O_ddP_O" / _f32(3),
    "elbow_c" / _f32(2),
    "delbow_c" / _f32(2),
    "ddelbow_c" / _f32(2),
    "O_T_EE_c" / _f32(16),
    "O_dP_EE_c" / _f32(6),
    "O_ddP_EE_c" / _f32(6),
    "theta" / _f32(7),
    "dtheta" / _f32(7),
    "accelerometer_top" / _f32(18),
    "accelerometer_bottom" / _f32(18),
    "motion_generator_mode" / Enum(Int8ul, MotionGeneratorMode),
    "controller_mode" / Enum(Int8ul, ControllerMode),
    "errors" / Array(NUM_ERRORS, Flag),  # currently active errors
    "reflex_reason" / Array(NUM_ERRORS, Flag),  # errors that aborted the last motion
    "robot_mode" / Enum(Int8ul, RobotMode),
    "control_command_success_rate" / Float32l,
)

ROBOT_STATE_SIZE = 1377
assert RobotState.sizeof() == ROBOT_STATE_SIZE, RobotState.sizeof()
