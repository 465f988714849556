"""A panda-python 1.1.1 program (libfranka 0.9.2, robot protocol v5), run in a virtual
environment of its own (tests/clients/test_panda_python.py makes it).

    python tests/support/panda_py_program.py HOST PLAN_JSON

connects as a Panda user would and prints one JSON line: the state it reads; what its Model
(the model library the robot sends) computes at each of the plan's `poses`; move_to_start;
move_to_joint_position to `target`; move_to_pose 5 cm above the start pose; a torque
controller (panda_py.controllers.JointPosition) holding `held` for 5 s of robot time; the
Hand's homing and move, and a pick of the cube through `above` and `at`.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
import panda_py
from panda_py import controllers, libfranka


def _matrix(column_major) -> list:
    return np.reshape(column_major, (4, 4), order="F").tolist()


def main(host: str, plan: dict) -> dict:
    panda = panda_py.Panda(host)
    state = panda.get_state()
    out = {"q": list(state.q), "mode": str(state.robot_mode).rsplit(".", 1)[-1],
           "F_T_EE": _matrix(state.F_T_EE), "message_id": state.time.to_msec()}
    out["model"] = _model(panda.get_model(), state, plan["poses"])
    out["start"] = {"done": panda.move_to_start(), "q": list(panda.q)}
    out["joint"] = {"done": panda.move_to_joint_position(np.array(plan["target"])),
                    "q": list(panda.q)}
    panda.move_to_start()
    goal = np.array(panda.get_pose())
    goal[2, 3] += 0.05
    out["pose"] = {"done": panda.move_to_pose(goal), "goal": goal.tolist(),
                   "reached": np.array(panda.get_pose()).tolist()}
    out["torque"] = _hold(panda, np.array(plan["held"]))
    out["gripper"] = _gripper(panda, host, plan)
    return out


def _model(model, state, poses: list) -> list:
    """Mass matrix, gravity, the end effector's pose and zero Jacobian at each pose, with the
    state's end effector and load (column-major, as libfranka returns them)."""
    F_T_EE, EE_T_K = state.F_T_EE, state.EE_T_K
    I_total, m_total, F_x_Ctotal = state.I_total, state.m_total, state.F_x_Ctotal
    return [{
        "mass": np.reshape(model.mass(q, I_total, m_total, F_x_Ctotal), (7, 7)).tolist(),
        "gravity": list(model.gravity(q, m_total, F_x_Ctotal)),
        "ee": _matrix(model.pose(libfranka.Frame.kEndEffector, q, F_T_EE, EE_T_K)),
        "joint4": _matrix(model.pose(libfranka.Frame.kJoint4, q, F_T_EE, EE_T_K)),
        "J_ee": np.reshape(model.zero_jacobian(libfranka.Frame.kEndEffector, q, F_T_EE, EE_T_K),
                           (6, 7), order="F").tolist(),
    } for q in poses]


def _hold(panda, held: np.ndarray) -> dict:
    """A torque controller of panda_py.controllers (an impedance law the client computes)
    holding `held` (near the start pose: its default gains are stiff) until its own clock,
    the robot's, says 5 s; a minute of wall time at most (a reflex ends it sooner)."""
    panda.move_to_start()
    controller = controllers.JointPosition()
    panda.start_controller(controller)
    controller.set_control(held)
    deadline = time.monotonic() + 60.0
    while controller.get_time() < 5.0 and time.monotonic() < deadline:
        time.sleep(0.01)
    ran = controller.get_time()
    q = list(panda.q)
    panda.stop_controller()
    return {"ran": ran, "q": q}


def _gripper(panda, host: str, plan: dict) -> dict:
    gripper = libfranka.Gripper(host)
    homed = gripper.homing()
    moved = gripper.move(0.07, 0.1)
    width = gripper.read_once().width
    panda.move_to_joint_position(np.array(plan["above"]))
    panda.move_to_joint_position(np.array(plan["at"]), speed_factor=0.1)
    grasped = gripper.grasp(0.05, 0.1, 20.0, 0.005, 0.005)
    panda.move_to_joint_position(np.array(plan["above"]), speed_factor=0.1)
    held = gripper.read_once()
    return {"homed": homed, "moved": moved, "width": width, "grasped": grasped,
            "is_grasped": held.is_grasped, "held_width": held.width}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], json.loads(sys.argv[2]))))
