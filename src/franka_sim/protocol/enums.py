"""Enumerations and constants of the FCI wire protocol (robot v10, gripper v3).

Member names follow the FCI spelling (``kMotionStarted``, ``kJointImpedance``) so that a
decoded packet, a libfranka log line and our code all use the same words.

Two pairs of enums look alike but must not be mixed up: the Move *request* numbers its motion
generators from ``kJointPosition = 0``, while the *state* reports ``kIdle = 0`` first and shifts
everything by one. ``STATE_MOTION_GENERATOR_MODE`` is the single place that translates.
"""

from enum import IntEnum

ROBOT_VERSION = 10
GRIPPER_VERSION = 3
ROBOT_COMMAND_PORT = 1337
GRIPPER_COMMAND_PORT = 1338


class Command(IntEnum):
    """Robot TCP command ids (uint32 on the wire). GetRobotModel is 11 since v10."""

    Connect = 0
    Move = 1
    StopMove = 2
    SetCollisionBehavior = 3
    SetJointImpedance = 4
    SetCartesianImpedance = 5
    SetGuidingMode = 6
    SetEEToK = 7
    SetNEToEE = 8
    SetLoad = 9
    AutomaticErrorRecovery = 10
    GetRobotModel = 11


class ConnectStatus(IntEnum):
    kSuccess = 0
    kIncompatibleLibraryVersion = 1


class BaseStatus(IntEnum):
    """Status of commands without a specific enum (GetRobotModel)."""

    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kCommandRejectedDueToActivatedSafetyFunctions = 2


class GetterSetterStatus(IntEnum):
    """Status of every Set* command."""

    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kInvalidArgumentRejected = 2
    kCommandRejectedDueToActivatedSafetyFunctions = 3


class MoveStatus(IntEnum):
    kSuccess = 0
    kMotionStarted = 1
    kPreempted = 2
    kPreemptedDueToActivatedSafetyFunctions = 3
    kCommandRejectedDueToActivatedSafetyFunctions = 4
    kCommandNotPossibleRejected = 5
    kStartAtSingularPoseRejected = 6
    kInvalidArgumentRejected = 7
    kReflexAborted = 8
    kEmergencyAborted = 9
    kInputErrorAborted = 10
    kAborted = 11


class StopMoveStatus(IntEnum):
    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kCommandRejectedDueToActivatedSafetyFunctions = 2
    kEmergencyAborted = 3
    kReflexAborted = 4
    kAborted = 5


class AutomaticErrorRecoveryStatus(IntEnum):
    kSuccess = 0
    kCommandNotPossibleRejected = 1
    kCommandRejectedDueToActivatedSafetyFunctions = 2
    kManualErrorRecoveryRequiredRejected = 3
    kReflexAborted = 4
    kEmergencyAborted = 5
    kAborted = 6


class MoveControllerMode(IntEnum):
    """Controller requested by a Move (uint32)."""

    kJointImpedance = 0
    kCartesianImpedance = 1
    kExternalController = 2


class MoveMotionGeneratorMode(IntEnum):
    """Motion generator requested by a Move (uint32); kNone means torque-only."""

    kJointPosition = 0
    kJointVelocity = 1
    kCartesianPosition = 2
    kCartesianVelocity = 3
    kNone = 4


class MotionGeneratorMode(IntEnum):
    """Motion generator reported in RobotState (uint8); note kIdle = 0 shifts the rest."""

    kIdle = 0
    kJointPosition = 1
    kJointVelocity = 2
    kCartesianPosition = 3
    kCartesianVelocity = 4
    kNone = 5


class ControllerMode(IntEnum):
    """Controller reported in RobotState (uint8)."""

    kJointImpedance = 0
    kCartesianImpedance = 1
    kExternalController = 2
    kOther = 3


class RobotMode(IntEnum):
    """Robot mode reported in RobotState (uint8), numbered like franka::RobotMode."""

    kOther = 0
    kIdle = 1
    kMove = 2
    kGuiding = 3
    kReflex = 4
    kUserStopped = 5
    kAutomaticErrorRecovery = 6


# The client waits for the state to show exactly these modes before it starts its control
# loop, so a Move must be answered by reporting the mapped value, not the requested number.
STATE_MOTION_GENERATOR_MODE: dict[MoveMotionGeneratorMode, MotionGeneratorMode] = {
    MoveMotionGeneratorMode.kJointPosition: MotionGeneratorMode.kJointPosition,
    MoveMotionGeneratorMode.kJointVelocity: MotionGeneratorMode.kJointVelocity,
    MoveMotionGeneratorMode.kCartesianPosition: MotionGeneratorMode.kCartesianPosition,
    MoveMotionGeneratorMode.kCartesianVelocity: MotionGeneratorMode.kCartesianVelocity,
    MoveMotionGeneratorMode.kNone: MotionGeneratorMode.kNone,
}

# Controllers keep their numbers; the table exists so callers never rely on that by accident.
STATE_CONTROLLER_MODE: dict[MoveControllerMode, ControllerMode] = {
    MoveControllerMode.kJointImpedance: ControllerMode.kJointImpedance,
    MoveControllerMode.kCartesianImpedance: ControllerMode.kCartesianImpedance,
    MoveControllerMode.kExternalController: ControllerMode.kExternalController,
}


class GripperCommand(IntEnum):
    """Gripper TCP command ids (uint16 on the wire, unlike the robot's uint32)."""

    Connect = 0
    Homing = 1
    Grasp = 2
    Move = 3
    Stop = 4


class GripperConnectStatus(IntEnum):
    kSuccess = 0
    kIncompatibleLibraryVersion = 1


class GripperStatus(IntEnum):
    """Status of Homing/Grasp/Move/Stop (uint16). kUnsuccessful makes the client return False."""

    kSuccess = 0
    kFail = 1
    kUnsuccessful = 2
    kAborted = 3


VACUUM_GRIPPER_VERSION = 1  # every libfranka tag from 0.8.0 on (docs/tools.md)
VACUUM_GRIPPER_COMMAND_PORT = 1339


class VacuumGripperCommand(IntEnum):
    """Vacuum gripper (Cobot Pump) TCP command ids (uint16 on the wire, as the Hand's)."""

    Connect = 0
    Vacuum = 1
    DropOff = 2
    Stop = 3


class VacuumGripperConnectStatus(IntEnum):
    kSuccess = 0
    kIncompatibleLibraryVersion = 1


class VacuumGripperStatus(IntEnum):
    """Status of Vacuum/DropOff/Stop (uint16): the Hand's four, with the same meanings."""

    kSuccess = 0
    kFail = 1
    kUnsuccessful = 2
    kAborted = 3


class VacuumGripperProfile(IntEnum):
    """The pump's production setup profile (uint8), P0 to P3."""

    kP0 = 0
    kP1 = 1
    kP2 = 2
    kP3 = 3


class VacuumGripperDeviceStatus(IntEnum):
    """The device's own health (uint8), a traffic light."""

    kGreen = 0
    kYellow = 1
    kOrange = 2
    kRed = 3
