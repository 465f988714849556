"""The tables make_golden.py places values with: command and status numbers, enum names, and
each message's layout (offset, field, `struct` format), restated from robot_v10.md,
robot_v9.md, robot_v5.md, gripper_v3.md and vacuum_gripper_v1.md. Like make_golden.py, this
imports nothing of franka_sim."""


def _numbered(names):
    return {n: i for i, n in enumerate(names.split())}


COMMAND = _numbered(
    "Connect Move StopMove SetCollisionBehavior SetJointImpedance SetCartesianImpedance "
    "SetGuidingMode SetEEToK SetNEToEE SetLoad AutomaticErrorRecovery GetRobotModel")
GRIPPER_COMMAND = _numbered("Connect Homing Grasp Move Stop")
VACUUM_COMMAND = _numbered("Connect Vacuum DropOff Stop")

# Status tables, restated from the .md files (the same name means different numbers per table).
CONNECT_STATUS = _numbered("kSuccess kIncompatibleLibraryVersion")
BASE_STATUS = _numbered("kSuccess kCommandNotPossibleRejected "
                        "kCommandRejectedDueToActivatedSafetyFunctions")
GETTER_SETTER_STATUS = _numbered(
    "kSuccess kCommandNotPossibleRejected kInvalidArgumentRejected "
    "kCommandRejectedDueToActivatedSafetyFunctions")
MOVE_STATUS = _numbered(
    "kSuccess kMotionStarted kPreempted kPreemptedDueToActivatedSafetyFunctions "
    "kCommandRejectedDueToActivatedSafetyFunctions kCommandNotPossibleRejected "
    "kStartAtSingularPoseRejected kInvalidArgumentRejected kReflexAborted kEmergencyAborted "
    "kInputErrorAborted kAborted")
STOP_MOVE_STATUS = _numbered(
    "kSuccess kCommandNotPossibleRejected kCommandRejectedDueToActivatedSafetyFunctions "
    "kEmergencyAborted kReflexAborted kAborted")
AER_STATUS = _numbered(
    "kSuccess kCommandNotPossibleRejected kCommandRejectedDueToActivatedSafetyFunctions "
    "kManualErrorRecoveryRequiredRejected kReflexAborted kEmergencyAborted kAborted")
GRIPPER_CONNECT_STATUS = CONNECT_STATUS
GRIPPER_STATUS = _numbered("kSuccess kFail kUnsuccessful kAborted")
VACUUM_STATUS = GRIPPER_STATUS
VACUUM_PROFILE = _numbered("kP0 kP1 kP2 kP3")
VACUUM_DEVICE_STATUS = _numbered("kGreen kYellow kOrange kRed")
STATUS_OF = {"Connect": CONNECT_STATUS, "Move": MOVE_STATUS, "StopMove": STOP_MOVE_STATUS,
             "AutomaticErrorRecovery": AER_STATUS, "GetRobotModel": BASE_STATUS}
MOVE_CONTROLLER_MODE = _numbered("kJointImpedance kCartesianImpedance kExternalController")
MOVE_MOTION_GENERATOR_MODE = _numbered(
    "kJointPosition kJointVelocity kCartesianPosition kCartesianVelocity kNone")
STATE_ENUMS = {
    "motion_generator_mode": _numbered(
        "kIdle kJointPosition kJointVelocity kCartesianPosition kCartesianVelocity kNone"),
    "controller_mode": _numbered(
        "kJointImpedance kCartesianImpedance kExternalController kOther"),
    "robot_mode": _numbered(
        "kOther kIdle kMove kGuiding kReflex kUserStopped kAutomaticErrorRecovery"),
}

# RobotState, robot_v10.md: (offset, name, struct format)
STATE_LAYOUT = [
    (0, "message_id", "Q"), (8, "O_T_EE", "16f"), (72, "O_T_EE_d", "16f"),
    (136, "F_T_EE", "16f"), (200, "EE_T_K", "16f"), (264, "F_T_NE", "16f"),
    (328, "NE_T_EE", "16f"), (392, "m_ee", "f"), (396, "I_ee", "9f"), (432, "F_x_Cee", "3f"),
    (444, "m_load", "f"), (448, "I_load", "9f"), (484, "F_x_Cload", "3f"), (496, "elbow", "2f"),
    (504, "elbow_d", "2f"), (512, "tau_J", "7f"), (540, "tau_J_d", "7f"), (568, "dtau_J", "7f"),
    (596, "q", "7f"), (624, "q_d", "7f"), (652, "dq", "7f"), (680, "dq_d", "7f"),
    (708, "ddq_d", "7f"), (736, "joint_contact", "7f"), (764, "cartesian_contact", "6f"),
    (788, "joint_collision", "7f"), (816, "cartesian_collision", "6f"),
    (840, "tau_ext_hat_filtered", "7f"), (868, "O_F_ext_hat_K", "6f"),
    (892, "K_F_ext_hat_K", "6f"), (916, "O_dP_EE_d", "6f"), (940, "O_ddP_O", "3f"),
    (952, "elbow_c", "2f"), (960, "delbow_c", "2f"), (968, "ddelbow_c", "2f"),
    (976, "O_T_EE_c", "16f"), (1040, "O_dP_EE_c", "6f"), (1064, "O_ddP_EE_c", "6f"),
    (1088, "theta", "7f"), (1116, "dtheta", "7f"), (1144, "accelerometer_top", "18f"),
    (1216, "accelerometer_bottom", "18f"), (1288, "motion_generator_mode", "B"),
    (1289, "controller_mode", "B"), (1290, "errors", "41?"), (1331, "reflex_reason", "41?"),
    (1372, "robot_mode", "B"), (1373, "control_command_success_rate", "f"),
]
# RobotState of robot protocol 9, robot_v9.md: v10's fields but the accelerometers, float64.
STATE_V9_LAYOUT = [
    (0, "message_id", "Q"), (8, "O_T_EE", "16d"), (136, "O_T_EE_d", "16d"),
    (264, "F_T_EE", "16d"), (392, "EE_T_K", "16d"), (520, "F_T_NE", "16d"),
    (648, "NE_T_EE", "16d"), (776, "m_ee", "d"), (784, "I_ee", "9d"), (856, "F_x_Cee", "3d"),
    (880, "m_load", "d"), (888, "I_load", "9d"), (960, "F_x_Cload", "3d"), (984, "elbow", "2d"),
    (1000, "elbow_d", "2d"), (1016, "tau_J", "7d"), (1072, "tau_J_d", "7d"),
    (1128, "dtau_J", "7d"), (1184, "q", "7d"), (1240, "q_d", "7d"), (1296, "dq", "7d"),
    (1352, "dq_d", "7d"), (1408, "ddq_d", "7d"), (1464, "joint_contact", "7d"),
    (1520, "cartesian_contact", "6d"), (1568, "joint_collision", "7d"),
    (1624, "cartesian_collision", "6d"), (1672, "tau_ext_hat_filtered", "7d"),
    (1728, "O_F_ext_hat_K", "6d"), (1776, "K_F_ext_hat_K", "6d"), (1824, "O_dP_EE_d", "6d"),
    (1872, "O_ddP_O", "3d"), (1896, "elbow_c", "2d"), (1912, "delbow_c", "2d"),
    (1928, "ddelbow_c", "2d"), (1944, "O_T_EE_c", "16d"), (2072, "O_dP_EE_c", "6d"),
    (2120, "O_ddP_EE_c", "6d"), (2168, "theta", "7d"), (2224, "dtheta", "7d"),
    (2280, "motion_generator_mode", "B"), (2281, "controller_mode", "B"),
    (2282, "errors", "41?"), (2323, "reflex_reason", "41?"), (2364, "robot_mode", "B"),
    (2365, "control_command_success_rate", "d"),
]
# Command ids of robot protocol 9, robot_v9.md.
COMMAND_V9 = _numbered(
    "Connect Move StopMove SetCollisionBehavior SetJointImpedance SetCartesianImpedance "
    "SetGuidingMode SetEEToK SetNEToEE SetLoad AutomaticErrorRecovery LoadModelLibrary "
    "GetRobotModel")
# Command ids of robot protocols 5 and 6, and the status tables 5 has, robot_v5.md.
COMMAND_V5 = _numbered(
    "Connect Move StopMove GetCartesianLimit SetCollisionBehavior SetJointImpedance "
    "SetCartesianImpedance SetGuidingMode SetEEToK SetNEToEE SetLoad SetFilters "
    "AutomaticErrorRecovery LoadModelLibrary")
COMMAND_V6 = _numbered(
    "Connect Move StopMove SetCollisionBehavior SetJointImpedance SetCartesianImpedance "
    "SetGuidingMode SetEEToK SetNEToEE SetLoad AutomaticErrorRecovery LoadModelLibrary")
GETTER_SETTER_STATUS_V5 = _numbered(
    "kSuccess kCommandNotPossibleRejected kInvalidArgumentRejected")
MOVE_STATUS_V5 = _numbered(
    "kSuccess kMotionStarted kPreempted kCommandNotPossibleRejected "
    "kStartAtSingularPoseRejected kInvalidArgumentRejected kReflexAborted kEmergencyAborted "
    "kInputErrorAborted kAborted")
ARCHITECTURE_V9 = _numbered("kX64 kX86 kARM kARM64")
SYSTEM_V9 = _numbered("kLinux kWindows")
LOAD_MODEL_LIBRARY_STATUS_V9 = _numbered("kSuccess kError")
COMMAND_LAYOUT = [
    (0, "message_id", "Q"), (8, "q_c", "7d"), (64, "dq_c", "7d"), (120, "O_T_EE_c", "16d"),
    (248, "O_dP_EE_c", "6d"), (296, "elbow_c", "2d"), (312, "valid_elbow", "?"),
    (313, "motion_generation_finished", "?"), (314, "tau_J_d", "7d"),
    (370, "torque_command_finished", "?"),
]
ROBOT_HEADER = [(0, "header.command", "I"), (4, "header.command_id", "I"), (8, "header.size", "I")]
GRIPPER_HEADER = [(0, "header.command", "H"), (2, "header.command_id", "I"),
                  (6, "header.size", "I")]
