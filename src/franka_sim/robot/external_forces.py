"""The robot's external-force estimate and its contact/collision flags, once per cycle.

The physics measures the external joint torque exactly (Measured.tau_ext: Jᵀ·(the wrench the
robot exerts on its environment), the declared load's model subtracted — the robot's sign, in
which a force the robot applies to the environment is positive). The robot reports it as
tau_ext_hat_filtered, through a first-order low-pass like its estimator's, and maps it to the
wrench at the stiffness frame K: O_F_ext_hat_K = pinv(J_Kᵀ)·tau, and K_F_ext_hat_K, the same
wrench in K's axes. Near a singularity the robot reports a zero wrench; so do we.

Flags (libfranka robot_state.h, robot.h): a value over its lower threshold is a contact, which
clears when the value drops; over its upper threshold it is a collision, latched until the next
automatic error recovery. The joint flags judge tau_ext_hat_filtered, the Cartesian ones
K_F_ext_hat_K. A collision is what stops a running motion with joint_reflex / cartesian_reflex
(the core decides that; here we only say which).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from franka_sim.description.hand import flange_to_ee
from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.robot.cartesian import ee_jacobian
from franka_sim.robot.settings import CollisionThresholds, RobotSettings

# The robot's estimator cutoff is unpublished (docs/figures.md, "Collision and estimator
# settings"). 20 Hz: a step in force is 95 % in after 24 ms, fast enough for the reflex to follow
# an impact within a few cycles, and it smooths MuJoCo's contact solver from step to step.
FILTER_CUTOFF_HZ = 20.0
FILTER_GAIN = 1.0 - math.exp(-2.0 * math.pi * FILTER_CUTOFF_HZ * DT)
# A decayed estimate below this is exactly zero again, so a contact-free arm costs nothing
# per cycle (and the filter never crawls through denormals).
FLUSH_BELOW = 1e-9  # Nm
# O_F_ext_hat_K reads zeros when J_K's smallest singular value is under this: the threshold of
# the Cartesian singular-start check (the ready pose has ≈ 0.22; a stretched arm ≈ 0.046).
WRENCH_MIN_SINGULAR_VALUE = 0.02
# The "acceleration" threshold set applies while the motion generator accelerates or brakes:
# some joint's desired acceleration |ddq_d| above this. Otherwise (constant velocity, idle,
# torque control without a generator) the "nominal" set applies.
ACCELERATION_PHASE = 0.5  # rad/s²

JOINT_REFLEX = "joint_reflex"
CARTESIAN_REFLEX = "cartesian_reflex"


class Thresholds(NamedTuple):
    """The threshold set in force this cycle."""

    lower_torque: np.ndarray  # (7,) Nm
    upper_torque: np.ndarray  # (7,) Nm
    lower_force: np.ndarray  # (6,) N, Nm
    upper_force: np.ndarray  # (6,) N, Nm


def active_thresholds(c: CollisionThresholds, accelerating: bool) -> Thresholds:
    """SetCollisionBehavior's acceleration set while accelerating, its nominal set otherwise."""
    if accelerating:
        return Thresholds(c.lower_torque_acceleration, c.upper_torque_acceleration,
                          c.lower_force_acceleration, c.upper_force_acceleration)
    return Thresholds(c.lower_torque_nominal, c.upper_torque_nominal,
                      c.lower_force_nominal, c.upper_force_nominal)


def accelerating(ddq_d: np.ndarray | None) -> bool:
    """Whether a generator's desired acceleration puts the motion in an acceleration phase."""
    return ddq_d is not None and float(np.max(np.abs(ddq_d))) > ACCELERATION_PHASE


def wrench_at_K(tau: np.ndarray, O_T_F: np.ndarray, J_F: np.ndarray,
                F_T_K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(O_F, K_F): pinv(J_Kᵀ)·tau in the base frame and in K's axes; zeros near a singularity."""
    J_K = ee_jacobian(O_T_F, J_F, F_T_K)
    # pinv(J_Kᵀ) = (J_K·J_Kᵀ)⁻¹·J_K for a J_K of full row rank; the eigenvalues of J_K·J_Kᵀ are
    # its squared singular values. (An SVD of J_K costs about twice as much per cycle.)
    eigenvalues, V = np.linalg.eigh(J_K @ J_K.T)
    if eigenvalues[0] < WRENCH_MIN_SINGULAR_VALUE**2:
        return np.zeros(6), np.zeros(6)
    O_F = V @ ((V.T @ (J_K @ tau)) / eigenvalues)
    R = O_T_F[:3, :3] @ F_T_K[:3, :3]
    K_F = (O_F.reshape(2, 3) @ R).ravel()  # force and moment, each Rᵀ·v
    return O_F, K_F


class ExternalForces:
    """The estimate and flags the RobotState reports; `version` moves whenever they change.

    The flags are judged on one 13-vector (7 joint torques, then K_F_ext_hat_K) against the
    thresholds stacked the same way; the per-field arrays are views into it.
    """

    def __init__(self) -> None:
        self.tau_ext_hat_filtered = np.zeros(7)
        self.O_F_ext_hat_K = np.zeros(6)
        self.K_F_ext_hat_K = np.zeros(6)
        self._contact = np.zeros(13, dtype=bool)
        self._collision = np.zeros(13, dtype=bool)  # latched until clear_collisions()
        self._active = False  # the estimate is not all zero
        self._stacked: tuple | None = None  # (thresholds, lower (13,), upper (13,))
        self._F_T_K: tuple | None = None  # (NE_T_EE, EE_T_K, F_T_K), rebuilt when they change
        self.version = 0

    joint_contact = property(lambda self: self._contact[:7])
    cartesian_contact = property(lambda self: self._contact[7:])
    joint_collision = property(lambda self: self._collision[:7])
    cartesian_collision = property(lambda self: self._collision[7:])

    def untouched(self, tau_ext: np.ndarray | None) -> bool:
        """Nothing touches the arm and the estimate has decayed: an update would change nothing."""
        # any() of a list: ndarray.any() costs ~1 µs per cycle through its Python wrapper
        return not self._active and (tau_ext is None or not any(tau_ext.tolist()))

    def estimate(self, measured, settings: RobotSettings, ddq_d: np.ndarray | None) -> list[str]:
        """One cycle's estimate and flags under the client's thresholds and frames; the
        reflexes a collision calls for. `ddq_d`: the generator's acceleration (None: none)."""
        thresholds = active_thresholds(settings.collision, accelerating(ddq_d))
        return self.update(measured.tau_ext, measured.O_T_F, measured.J_F,
                           self._flange_to_K(settings), thresholds)

    def _flange_to_K(self, settings: RobotSettings) -> np.ndarray:
        cached = self._F_T_K
        if (cached is None or cached[0] is not settings.NE_T_EE
                or cached[1] is not settings.EE_T_K):
            cached = self._F_T_K = (settings.NE_T_EE, settings.EE_T_K,
                                    flange_to_ee(settings.NE_T_EE) @ settings.EE_T_K)
        return cached[2]

    def update(self, tau_ext: np.ndarray | None, O_T_F: np.ndarray, J_F: np.ndarray | None,
               F_T_K: np.ndarray, thresholds: Thresholds) -> list[str]:
        """Take one cycle's measured external torque; return the reflexes a collision calls for
        (joint_reflex, cartesian_reflex), whether or not a motion runs to be stopped."""
        quiet_input = tau_ext is None or not tau_ext.any()
        if quiet_input and not self._active:
            return []  # all stays zero
        tau = self.tau_ext_hat_filtered
        if quiet_input:
            tau = tau * (1.0 - FILTER_GAIN)
            if float(np.max(np.abs(tau))) < FLUSH_BELOW:
                tau = np.zeros(7)
        else:
            tau = tau + FILTER_GAIN * (tau_ext - tau)
        self.tau_ext_hat_filtered = tau
        self._active = not quiet_input or bool(tau.any())
        if J_F is not None and self._active:
            self.O_F_ext_hat_K, self.K_F_ext_hat_K = wrench_at_K(tau, O_T_F, J_F, F_T_K)
        else:
            self.O_F_ext_hat_K, self.K_F_ext_hat_K = np.zeros(6), np.zeros(6)
        lower, upper = self._stacked_thresholds(thresholds)
        values = np.abs(np.concatenate((tau, self.K_F_ext_hat_K)))
        self._contact = values > lower
        over = values > upper
        self._collision = self._collision | over
        self.version += 1
        if not over.any():
            return []
        return ([JOINT_REFLEX] if over[:7].any() else []) + (
            [CARTESIAN_REFLEX] if over[7:].any() else [])

    def _stacked_thresholds(self, t: Thresholds) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) as 13-vectors, rebuilt only when the threshold arrays change."""
        cached = self._stacked
        if cached is None or any(a is not b for a, b in zip(t, cached[0])):
            cached = self._stacked = (t, np.concatenate((t.lower_torque, t.lower_force)),
                                      np.concatenate((t.upper_torque, t.upper_force)))
        return cached[1], cached[2]

    def reset(self) -> None:
        """Nothing on record: the estimate, the wrench and every flag zero (a robot reset)."""
        self.tau_ext_hat_filtered = np.zeros(7)
        self.O_F_ext_hat_K, self.K_F_ext_hat_K = np.zeros(6), np.zeros(6)
        self._contact = np.zeros(13, dtype=bool)
        self._collision = np.zeros(13, dtype=bool)
        self._active = False
        self.version += 1

    def clear_collisions(self) -> None:
        """Automatic error recovery resets the latched collision flags."""
        if self._collision.any():
            self._collision = np.zeros(13, dtype=bool)
            self.version += 1
