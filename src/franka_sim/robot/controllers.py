"""The robot's internal joint controller: impedance about the desired joint signals.

Every mode but pure torque control ends here: the drives get K·(q_d − q) + D·(dq_d − dq) on
top of the gravity compensation the physics adds. K is SetJointImpedance's K_theta.
"""

from __future__ import annotations

import numpy as np

from franka_sim.spatial import pose_error

# The joint-space inertia diagonal (rotors included) near the ready pose, kg·m², rounded; only
# used to derive the impedance damping from the stiffness. Even at K = 14250 and the lightest
# pose the explicit 1 kHz damping term stays inside its stability bound (D·dt/J < 2).
NOMINAL_JOINT_INERTIA = np.array([0.8, 1.8, 1.2, 1.2, 0.12, 0.13, 0.08])


def impedance_damping(K: np.ndarray) -> np.ndarray:
    """The damping the internal joint impedance derives from its stiffness.

    The robot's law is unpublished ("damping is derived from the stiffness"); we use critical
    damping against a nominal reflected inertia, far inside the explicit 1 kHz stability bound
    for every K in the allowed range.
    """
    return 2.0 * np.sqrt(K * NOMINAL_JOINT_INERTIA)


# Cartesian impedance: damping derived from the stiffness against a nominal apparent inertia
# at the EE (translation kg, rotation kg·m²), critically damped like the joint law.
NOMINAL_EE_INERTIA = np.array([2.0, 2.0, 2.0, 0.05, 0.05, 0.05])
# A weak joint impedance in the Cartesian law's null space keeps the redundant joint from
# drifting (the robot's own null-space behaviour is unpublished).
NULLSPACE_STIFFNESS = 10.0  # Nm/rad
NULLSPACE_DAMPING = 2.0 * np.sqrt(NULLSPACE_STIFFNESS * 0.5)
_EYE7 = np.eye(7)
_EYE7.setflags(write=False)


def cartesian_damping(K_x: np.ndarray) -> np.ndarray:
    """The damping the Cartesian impedance derives from its stiffness (critical, as above)."""
    return 2.0 * np.sqrt(K_x * NOMINAL_EE_INERTIA)


def cartesian_impedance_torque(K_x, D_x, O_T_K_d, O_T_K, J_K, dq, q_d, q,
                               dq_d=None) -> np.ndarray:
    """Joint torques of a Cartesian spring-damper in the stiffness frame K.

    K_x (SetCartesianImpedance) acts along the axes of K: a push on K displaces it by F/K_x;
    D_x is cartesian_damping(K_x). J_K is the base-frame Jacobian of K's origin; the pose error
    and the twist error (the desired twist, J_K·dq_d, less the measured one) are rotated into K,
    scaled, and rotated back: the robot tracks O_T_EE_d and O_dP_EE_d both, so a moving target
    is followed without a lag of D/K times its speed. Gravity is the physics' business (the
    robot adds it).
    """
    if dq_d is not None:
        dq = dq - dq_d  # (the damper acts on the velocity error)
    R = O_T_K[:3, :3]
    error_O = pose_error(O_T_K_d, O_T_K)
    velocity_O = J_K @ dq
    error_K = np.concatenate([R.T @ error_O[:3], R.T @ error_O[3:]])
    velocity_K = np.concatenate([R.T @ velocity_O[:3], R.T @ velocity_O[3:]])
    wrench_K = K_x * error_K - D_x * velocity_K
    wrench_O = np.concatenate([R @ wrench_K[:3], R @ wrench_K[3:]])
    tau = J_K.T @ wrench_O
    # Null space: J_K^T-consistent projector with the (damped) pseudo-inverse.
    J_pinv = np.linalg.pinv(J_K, rcond=1e-3)
    N = _EYE7 - J_K.T @ J_pinv.T
    tau_ns = NULLSPACE_STIFFNESS * (q_d - q) - NULLSPACE_DAMPING * dq
    return tau + N @ tau_ns
