"""The 41 robot error bits carried by RobotState.errors and RobotState.reflex_reason.

Both fields are arrays of 41 one-byte booleans; bit *i* means the error named ``ERROR_NAMES[i]``.
The names are the FCI ones (franka::Errors members) so that what we latch reads the same as what
libfranka prints in its ControlException text.
"""

from collections.abc import Iterable

ERROR_NAMES: tuple[str, ...] = (
    "joint_position_limits_violation",  # 0
    "cartesian_position_limits_violation",
    "self_collision_avoidance_violation",
    "joint_velocity_violation",
    "cartesian_velocity_violation",
    "force_control_safety_violation",  # 5
    "joint_reflex",
    "cartesian_reflex",
    "max_goal_pose_deviation_violation",
    "max_path_pose_deviation_violation",
    "cartesian_velocity_profile_safety_violation",  # 10
    "joint_position_motion_generator_start_pose_invalid",
    "joint_motion_generator_position_limits_violation",
    "joint_motion_generator_velocity_limits_violation",
    "joint_motion_generator_velocity_discontinuity",
    "joint_motion_generator_acceleration_discontinuity",  # 15
    "cartesian_position_motion_generator_start_pose_invalid",
    "cartesian_motion_generator_elbow_limit_violation",
    "cartesian_motion_generator_velocity_limits_violation",
    "cartesian_motion_generator_velocity_discontinuity",
    "cartesian_motion_generator_acceleration_discontinuity",  # 20
    "cartesian_motion_generator_elbow_sign_inconsistent",
    "cartesian_motion_generator_start_elbow_invalid",
    "force_controller_desired_force_tolerance_violation",
    "start_elbow_sign_inconsistent",
    "communication_constraints_violation",  # 25
    "power_limit_violation",
    "cartesian_motion_generator_joint_position_limits_violation",
    "cartesian_motion_generator_joint_velocity_limits_violation",
    "cartesian_motion_generator_joint_velocity_discontinuity",
    "cartesian_motion_generator_joint_acceleration_discontinuity",  # 30
    "cartesian_position_motion_generator_invalid_frame",
    "controller_torque_discontinuity",
    "joint_p2p_insufficient_torque_for_planning",
    "tau_J_range_violation",
    "instability_detected",  # 35
    "joint_move_in_wrong_direction",
    "cartesian_spline_motion_generator_violation",
    "joint_via_motion_generator_planning_joint_limit_violation",
    "base_acceleration_initialization_timeout",
    "base_acceleration_invalid_reading",  # 40
)

NUM_ERRORS = 41
assert len(ERROR_NAMES) == NUM_ERRORS and len(set(ERROR_NAMES)) == NUM_ERRORS

_INDEX = {name: i for i, name in enumerate(ERROR_NAMES)}


def error_index(name: str) -> int:
    """Bit index of an error name; a typo raises instead of silently setting nothing."""
    try:
        return _INDEX[name]
    except KeyError:
        raise KeyError(f"unknown FCI error name {name!r}") from None


def errors_to_names(bits: Iterable[object]) -> list[str]:
    """Names of the set bits of a 41-entry errors/reflex_reason array, in bit order."""
    bits = list(bits)
    if len(bits) != NUM_ERRORS:
        raise ValueError(f"expected {NUM_ERRORS} error bits, got {len(bits)}")
    return [name for name, bit in zip(ERROR_NAMES, bits, strict=True) if bit]
