"""A program of an older franky (franky-control 1.0.2: libfranka 0.15, robot protocol v9;
franky-panda 0.10.0: libfranka 0.13, v7), run in a virtual environment of its own
(tests/clients/test_older_libfranka.py makes it): they and the suite's franky 2.0.0 are one
package.

    python tests/support/older_franky_program.py HOST POSES_JSON

connects as a user would, prints the state it reads, what its Model (kinematics from the
model library the robot sends, dynamics from the URDF) computes at each of POSES (a list of q)
where the franky exposes one (1.0.2; 0.10.0 does not), a joint motion and a relative Cartesian
motion, and a Hand homing and move: one JSON line.
"""

from __future__ import annotations

import json
import sys

import franky
import numpy as np


def _matrix(pose) -> list:
    """An Affine (franky 1.x), or 16 numbers column-major (0.10's state), as rows."""
    if hasattr(pose, "matrix"):
        return np.asarray(pose.matrix).tolist()
    return np.reshape(pose, (4, 4), order="F").tolist()


def main(host: str, poses: list) -> dict:
    robot = franky.Robot(host, realtime_config=franky.RealtimeConfig.Ignore)
    robot.relative_dynamics_factor = 0.2
    state = robot.state
    out = {"q": list(state.q), "mode": state.robot_mode.name,
           "O_T_EE": _matrix(state.O_T_EE), "F_T_EE": _matrix(state.F_T_EE),
           "model": _model(robot.model, state, poses) if hasattr(robot, "model") else []}
    target = np.array(state.q) + [0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    robot.move(franky.JointMotion(target.tolist()))
    out["joint"] = {"target": target.tolist(), "q": list(robot.state.q)}
    before = np.asarray(robot.current_pose.end_effector_pose.translation)
    robot.move(franky.CartesianMotion(franky.Affine([0.0, 0.0, 0.05]),
                                      franky.ReferenceType.Relative))
    after = np.asarray(robot.current_pose.end_effector_pose.translation)
    out["cartesian"] = {"moved": (after - before).tolist(),
                        "mode": robot.state.robot_mode.name}
    gripper = franky.Gripper(host)
    homed = gripper.homing()
    moved = gripper.move(0.05, 0.1)
    out["gripper"] = {"homed": homed, "moved": moved, "width": gripper.width}
    return out


def _model(model, state, poses: list) -> list:
    """What the Model computes at each of `poses`, with the state's end effector."""
    F_T_EE, EE_T_K = state.F_T_EE, state.EE_T_K
    Frame = franky.Frame
    return [{
        "joint4": _matrix(model.pose(Frame.Joint4, np.array(q), F_T_EE, EE_T_K)),
        "ee": _matrix(model.pose(Frame.EndEffector, np.array(q), F_T_EE, EE_T_K)),
        "J_ee": model.zero_jacobian(Frame.EndEffector, np.array(q), F_T_EE, EE_T_K).tolist(),
        "body_J_flange": model.body_jacobian(Frame.Flange, np.array(q), F_T_EE,
                                             EE_T_K).tolist(),
        "gravity": list(model.gravity(np.array(q), state.m_total, np.array(state.F_x_Ctotal))),
        "mass": model.mass(np.array(q), np.asarray(state.I_total), state.m_total,
                           np.array(state.F_x_Ctotal)).tolist(),
    } for q in poses]


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], json.loads(sys.argv[2]))), flush=True)
