"""Torque control: a Cartesian spring-damper written by the client with Model.zero_jacobian.

Holds the end effector at its start pose (compliantly), as libfranka's
cartesian_impedance_control example does; coriolis is added, gravity is the robot's.
python cartesian_impedance_control.py HOST [SECONDS]
"""

import sys

import numpy as np
import pylibfranka

TRANSLATIONAL_STIFFNESS = 150.0
ROTATIONAL_STIFFNESS = 10.0


def _quaternion_error(R_d: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Orientation error as the vector part of the quaternion R_d⁻¹·R, in the base frame."""
    E = R_d.T @ R
    w = np.sqrt(max(1.0 + np.trace(E), 1e-12)) / 2.0
    v = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]]) / (4.0 * w)
    return R @ v


def main(host: str, seconds: float = 3.0) -> float:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    model = robot.load_model()
    K = np.diag([TRANSLATIONAL_STIFFNESS] * 3 + [ROTATIONAL_STIFFNESS] * 3)
    D = np.diag([2 * np.sqrt(TRANSLATIONAL_STIFFNESS)] * 3 + [2 * np.sqrt(ROTATIONAL_STIFFNESS)] * 3)
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    T_d = np.reshape(state.O_T_EE, (4, 4), order="F")
    time, worst = 0.0, 0.0
    while True:
        state, period = control.readOnce()
        time += period.to_sec()
        T = np.reshape(state.O_T_EE, (4, 4), order="F")
        J = np.reshape(model.zero_jacobian(state), (6, 7), order="F")
        error = np.concatenate([T[:3, 3] - T_d[:3, 3], _quaternion_error(T_d[:3, :3], T[:3, :3])])
        worst = max(worst, float(np.linalg.norm(error[:3])))
        dq = np.array(state.dq)
        tau = J.T @ (-K @ error - D @ (J @ dq)) + np.array(model.coriolis(state))
        command = pylibfranka.Torques(tau.tolist())
        if time >= seconds:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    print(f"max EE position error {worst * 1000:.3f} mm")
    return worst


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         float(sys.argv[2]) if len(sys.argv) > 2 else 3.0)
