"""Cartesian motion generators become joint motion: differential IK on the EE Jacobian.

Each cycle the commanded EE pose (kCartesianPosition, or the pose integrated from the commanded
twist for kCartesianVelocity) is solved to joint space with one damped-least-squares step from
the current desired joints q_d, using the pose and Jacobian of the EE frame at q_d — the frame
O_T_EE reports: flange ∘ F_T_EE. One step per 1 ms cycle suffices because consecutive commands
differ by micrometres; the residual is corrected on the next cycle. The joint-3 redundancy angle
(elbow_c[0]) is chased in the Jacobian's null space, so it moves the elbow without moving the EE.
The resulting q_d then goes through the same joint controller as a joint motion.
"""

from __future__ import annotations

import numpy as np

from franka_sim.protocol.timing import CYCLE_PERIOD as DT
from franka_sim.spatial import exp_rotation, rotation_vector, skew

# λ of the damped least squares: negligible against the ready pose's smallest singular value
# (≈ 0.23) and keeps the step bounded near singularities.
DLS_DAMPING = 1e-3
# A Cartesian Move is refused from a configuration whose EE Jacobian's smallest singular value
# is under this. Placed under the stretched-elbow pose at the joint-4 limit (σ_min ≈ 0.046),
# which real robots do start from, and well above truly singular poses (σ_min → 0).
SINGULAR_POSE_MIN_SINGULAR_VALUE = 0.02
ELBOW_GAIN = 1.0  # the elbow is a position command: close its error each cycle (null space)


def _constant(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


_EYE6 = _constant(np.eye(6))
_DLS_DAMPING_EYE = _constant(DLS_DAMPING**2 * np.eye(6))


def ee_jacobian(O_T_F: np.ndarray, J_F: np.ndarray, F_T_EE: np.ndarray) -> np.ndarray:
    """The flange Jacobian moved to the EE point: v_EE = v_F + ω × r."""
    r = O_T_F[:3, :3] @ F_T_EE[:3, 3]
    J = J_F.copy()
    J[:3] -= skew(r) @ J_F[3:]
    return J


def smallest_singular_value(J: np.ndarray) -> float:
    return float(np.linalg.svd(J, compute_uv=False)[-1])


def dls_step(J: np.ndarray, error: np.ndarray, elbow_error: float | None) -> np.ndarray:
    """Joint step toward `error` (6,), plus an elbow (joint 3) correction in the null space."""
    JJt = J @ J.T + _DLS_DAMPING_EYE
    J_pinv = J.T @ np.linalg.solve(JJt, _EYE6)
    dq = J_pinv @ error
    if elbow_error is not None:
        z = np.zeros(J.shape[1])
        z[2] = ELBOW_GAIN * elbow_error
        dq += z - J_pinv @ (J @ z)
    return dq


class CartesianTarget:
    """The commanded EE pose a Cartesian generator asks for, with the FCI's gap filling.

    For the velocity interface the pose is the integral of the commanded twist, so that the
    IK tracks a pose and never drifts; a missed cycle continues the twist at constant
    acceleration, as the robot extrapolates every motion signal. For the pose interface the
    twist (and its rate) is the poses' backward difference, which only a gap needs: it is
    worked out from the last three poses when one occurs, not on every cycle. After a gap the
    client's next pose or twist is differenced against its last, over the cycles between, not
    against what the gap carried on (motion.py JointReference says why).
    """

    def __init__(self, O_T_EE_start: np.ndarray, max_twist_rate: np.ndarray | float = np.inf,
                 max_twist: np.ndarray | float = np.inf) -> None:
        self.pose = np.array(O_T_EE_start, dtype=float)
        # m/s², rad/s² and m/s, rad/s per axis (6,): what a gap carries on, as the joint
        # reference's (motion.py)
        self.max_twist_rate, self.max_twist = max_twist_rate, max_twist
        self._twist = np.zeros(6)
        self._twist_rate = np.zeros(6)
        # The poses since the twist above was last brought up to date (it is the first one's),
        # the last three at most: the twist and its rate at the newest need no more.
        self._poses = [self.pose]
        self._stream = (self.pose, self._twist)  # the client's last pose and twist
        self._missed = 0  # cycles without a command since

    @property
    def twist(self) -> np.ndarray:
        self._settle()
        return self._twist

    def set_pose(self, O_T_EE_c: np.ndarray) -> None:
        self.pose = np.array(O_T_EE_c, dtype=float)
        if self._missed:
            cycles = self._missed + 1
            pose, twist = self._stream
            self._twist = _pose_rate(self.pose, pose) / cycles
            self._twist_rate = (self._twist - twist) / (cycles * DT)
            self._poses, self._missed = [self.pose], 0
            return
        poses = self._poses
        poses.append(self.pose)
        if len(poses) > 3:
            del poses[0]

    def _settle(self) -> None:
        """The twist and its rate at the newest pose, as if differenced at every set_pose."""
        poses = self._poses
        if len(poses) == 1:
            return
        previous = self._twist if len(poses) == 2 else _pose_rate(poses[1], poses[0])
        twist = _pose_rate(poses[-1], poses[-2])
        self._twist_rate = (twist - previous) / DT
        self._twist = twist
        self._poses = [poses[-1]]

    def set_twist(self, O_dP_EE_c: np.ndarray) -> None:
        twist = np.asarray(O_dP_EE_c, dtype=float)
        if self._missed:
            self._twist_rate = (twist - self._stream[1]) / ((self._missed + 1) * DT)
            self._missed = 0
        else:
            self._twist_rate = (twist - self.twist) / DT
        self._twist = twist.copy()
        self._integrate()

    def skip(self) -> None:
        """A cycle without a command (the robot carries on, or brakes the joints)."""
        self._settle()
        if not self._missed:
            self._stream = (self.pose.copy(), self._twist.copy())
        self._missed += 1

    def extrapolate(self) -> None:
        self.skip()
        limit, fastest = self.max_twist_rate, self.max_twist
        rate = np.clip(self._twist_rate, -limit, limit)
        twist = self._twist + rate * DT
        self._twist = np.clip(twist, -fastest, fastest)
        self._twist_rate = np.where(self._twist == twist, rate, 0.0)  # (at its limit: held)
        self._integrate()

    def _integrate(self) -> None:
        self.pose[:3, 3] += self._twist[:3] * DT
        self.pose[:3, :3] = exp_rotation(self._twist[3:] * DT) @ self.pose[:3, :3]
        self._poses = [self.pose]


def _pose_rate(T: np.ndarray, T_before: np.ndarray) -> np.ndarray:
    """The twist that took T_before to T in one cycle."""
    return np.concatenate([(T[:3, 3] - T_before[:3, 3]) / DT,
                           rotation_vector(T[:3, :3] @ T_before[:3, :3].T) / DT])
