"""Pick up the default scene's cube, carry it 20 cm to the side, put it down and let go.

The arm moves with pylibfranka joint-position motions (the robot's joint impedance controller
tracks them); the poses are solved here, offline, by a small damped-least-squares IK on
franka_sim's own forward kinematics, because a joint motion carries joint targets and the robot
computes no IK for it. The Franka Hand homes, grasps (20 N) and opens.

Run it against franka-sim on its default scene (a table, a 5 cm cube at (0.45, 0, 0.025)):
    python pick_and_place.py HOST
"""

from __future__ import annotations

import sys

import numpy as np
import pylibfranka

from franka_sim.description import hand
from franka_sim.description.kinematics import flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description

ARM = load_arm_description(default_urdf_text())
READY = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])
# End effector pointing down, fingers closing along the base's y axis (as at READY).
DOWN = np.diag([1.0, -1.0, -1.0])

CUBE = np.array([0.45, 0.0, 0.025])  # its centre in the default scene (scenes/default.xml)
PLACE = np.array([0.45, 0.20, 0.025])  # where it goes
CUBE_SIZE = 0.05
GRASP_ABOVE_CENTRE = 0.015  # TCP this far above the cube's centre: the pads on its upper half
APPROACH = 0.15  # m above the grasp height
GRASP_FORCE = 20.0  # N
SPEED = 0.1  # m/s, the Hand's opening speed


# -- offline IK: damped least squares on the forward kinematics ---------------------------------
def ee_pose(q: np.ndarray) -> np.ndarray:
    """O_T_EE with the Hand (the TCP between the fingertips)."""
    return flange_pose(ARM, q) @ hand.F_T_NE_HAND


def _pose_error(T: np.ndarray, position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    turn = 0.5 * sum(np.cross(T[:3, i], rotation[:, i]) for i in range(3))
    return np.concatenate([position - T[:3, 3], turn])


def _jacobian(q: np.ndarray, T: np.ndarray, h: float = 1e-7) -> np.ndarray:
    J = np.zeros((6, 7))
    for k in range(7):
        Tk = ee_pose(q + h * np.eye(7)[k])
        J[:3, k] = (Tk[:3, 3] - T[:3, 3]) / h
        W = (Tk[:3, :3] - T[:3, :3]) / h @ T[:3, :3].T
        J[3:, k] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


def solve_ik(position, seed, rotation=DOWN, damping=1e-6) -> np.ndarray:
    """Joint angles putting the TCP at `position` with `rotation`, staying close to `seed`."""
    q, seed = np.array(seed, float), np.array(seed, float)
    lower, upper = ARM.lower + 0.05, ARM.upper - 0.05
    for _ in range(300):
        T = ee_pose(q)
        error = _pose_error(T, np.asarray(position, float), rotation)
        if np.linalg.norm(error) < 1e-9:
            return q
        J = _jacobian(q, T)
        J_dls = J.T @ np.linalg.inv(J @ J.T + damping * np.eye(6))
        null_space = np.eye(7) - np.linalg.pinv(J) @ J  # exact, so the pull cannot bias the pose
        step = J_dls @ error + null_space @ (0.05 * (seed - q))  # keep the elbow near the seed
        step *= min(1.0, 0.1 / np.abs(step).max())
        q = np.clip(q + step, lower, upper)
    raise RuntimeError(f"no IK solution for {position}")


# -- motions --------------------------------------------------------------------------------------
def move_joints(robot: pylibfranka.Robot, q_goal, max_speed: float = 0.6) -> None:
    """A joint-position motion from where the arm is to q_goal (minimum-jerk profile)."""
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q_start = np.array(state.q_d)
    delta = np.asarray(q_goal, float) - q_start
    duration = max(0.5, 1.875 * np.abs(delta).max() / max_speed)  # peak speed = max_speed
    t = 0.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        s = min(t / duration, 1.0)
        q = q_start + delta * (10 * s**3 - 15 * s**4 + 6 * s**5)
        command = pylibfranka.JointPositions(q.tolist())
        command.motion_finished = t >= duration + 0.02  # finish after 20 ms at rest on the goal
        control.writeOnce(command)
        if command.motion_finished:
            break


def poses_over(point: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(approach pose APPROACH above the grasp, grasp pose) for an object centred at `point`."""
    at = solve_ik(point + [0.0, 0.0, GRASP_ABOVE_CENTRE], seed)
    above = solve_ik(point + [0.0, 0.0, GRASP_ABOVE_CENTRE + APPROACH], at)
    return above, at


def pick(robot, gripper, point, seed=READY) -> bool:
    """Descend over `point`, grasp a CUBE_SIZE object, lift; True if it was grasped."""
    above, at = poses_over(point, seed)
    gripper.move(0.08, SPEED)
    move_joints(robot, above)
    move_joints(robot, at, max_speed=0.3)
    grasped = gripper.grasp(CUBE_SIZE, SPEED, GRASP_FORCE)
    move_joints(robot, above, max_speed=0.3)
    return grasped


def place(robot, gripper, point, seed=READY) -> None:
    """Carry to over `point`, lower until the object rests there, open, retreat."""
    above, at = poses_over(point + [0.0, 0.0, 0.002], seed)  # let it down from 2 mm
    move_joints(robot, above)
    move_joints(robot, at, max_speed=0.3)
    gripper.move(0.08, SPEED)
    move_joints(robot, above, max_speed=0.3)


def main(host: str) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    gripper = pylibfranka.Gripper(host)
    robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
    robot.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 2000])
    gripper.homing()
    move_joints(robot, READY)
    if not pick(robot, gripper, CUBE):
        sys.exit("the grasp missed the cube")
    held = gripper.read_once()
    print(f"grasped: width {held.width:.4f} m, is_grasped {held.is_grasped}")
    place(robot, gripper, PLACE)
    move_joints(robot, READY)
    print("placed the cube at", PLACE.round(3).tolist())


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
