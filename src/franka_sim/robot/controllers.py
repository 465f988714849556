"""The robot's internal joint controller: impedance about the desired joint signals.

Every mode but pure torque control ends here: the drives get K·(q_d − q) + D·(dq_d − dq) on
top of the gravity compensation the physics adds. K is SetJointImpedance's K_theta.
"""

from __future__ import annotations

import numpy as np

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


def impedance_torque(K: np.ndarray, q_d, dq_d, q, dq) -> np.ndarray:
    """The impedance's torque without gravity: what the robot reports as tau_J_d."""
    return K * (q_d - q) + impedance_damping(K) * (dq_d - dq)
