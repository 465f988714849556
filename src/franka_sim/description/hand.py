"""The Franka Hand as the robot reports it to libfranka (docs/figures.md, "The Franka Hand").

These are the figures a real FR3 with a Hand, configured in Desk, puts into every RobotState
(m_ee, F_x_Cee, I_ee, F_T_NE): they come from the echo_robot_state dump published in Franka's
getting-started guide (2018, repeated in libfranka 0.21.2's docs), and franka_ros's Gazebo
plugin uses the same defaults "as Desk does for the hand". The hand's CAD inertials in
franka_description (0.65 kg body + two 0.03 kg fingers) differ slightly; we simulate the hand
with the *reported* figures so that a client's model (which uses the reported ones) matches
the physics exactly.
"""

from __future__ import annotations

import numpy as np


def _frozen(values) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


HAND_MASS = 0.73  # kg
HAND_COM = _frozen([-0.01, 0.0, 0.03])  # m, in the flange frame F
HAND_INERTIA = _frozen(np.diag([0.001, 0.0025, 0.0017]))  # kg·m², about the CoM, F axes

# Flange → nominal end effector (the TCP between the fingertips): −45° about z, 0.1034 m along z.
_c = np.sqrt(0.5)
F_T_NE_HAND = _frozen([
    [_c, _c, 0.0, 0.0],
    [-_c, _c, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.1034],
    [0.0, 0.0, 0.0, 1.0],
])


def combine_inertials(mass_a: float, com_a, inertia_a, mass_b: float, com_b, inertia_b):
    """One rigid body equivalent to two (e.g. the Hand plus a SetLoad payload).

    CoMs and tensors are in the same frame; tensors about their own CoM. Returns
    (mass, com, inertia about the combined CoM). With zero total mass the result is all zeros.
    """
    com_a, com_b = np.asarray(com_a, float), np.asarray(com_b, float)
    mass = float(mass_a + mass_b)
    if mass <= 0.0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    com = (mass_a * com_a + mass_b * com_b) / mass

    def shifted(m, c, inertia):  # parallel-axis theorem, moved to the combined CoM
        d = c - com
        return np.asarray(inertia, float) + m * (d @ d * np.eye(3) - np.outer(d, d))

    return mass, com, shifted(mass_a, com_a, inertia_a) + shifted(mass_b, com_b, inertia_b)


def flange_to_ee(NE_T_EE: np.ndarray) -> np.ndarray:
    """F_T_EE: the Hand's flange → nominal-EE transform, then the client's NE_T_EE (SetEEToK's
    sibling, set with SetNEToEE). Every frame the robot reports past the flange starts here."""
    return F_T_NE_HAND @ NE_T_EE
