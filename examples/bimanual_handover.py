"""Two arms hand the cube over: left picks it up and offers it, right takes it and keeps it.

Each arm is its own robot on its own address, driven by its own pylibfranka program in its own
process (two control loops in one process would starve each other); a multiprocessing Barrier
marks the moments the two must agree on: the cube is offered, taken, released.

Both Hands cannot hold a 5 cm cube from the same side, so the grasps split it: left takes it
from above by its upper part, fingers closing along x; right comes in from the side, hand level
and pointing +y, and closes along x on its lower part, its palm below left's fingers.

Positions are given in the world frame (the scene's) and turned into each arm's own base frame.
Each arm turns its hand once, with a joint motion to a pose solved by pick_and_place.py's
offline IK; from then on it moves in straight Cartesian lines (O_T_EE targets), its hand's
orientation kept.

Run it against franka-sim serving the two-arm scene:
    franka-sim serve --arm left=127.0.0.11 --arm right=127.0.0.12 --scene dual_arm_table
    python bimanual_handover.py 127.0.0.11 127.0.0.12
"""

from __future__ import annotations

import multiprocessing
import sys
import threading

import numpy as np
import pylibfranka

from pick_and_place import CUBE_SIZE, GRASP_FORCE, READY, SPEED, move_joints, solve_ik

BASE = {"left": np.array([0.0, 0.35, 0.0]), "right": np.array([0.0, -0.35, 0.0])}  # scene sites
CUBE = np.array([0.45, 0.15, 0.025])  # on the table, nearer the left arm
HANDOVER = np.array([0.45, 0.0, 0.30])  # the cube's centre while it changes hands
# Left: pointing down, fingers closing along x; TCP at the cube's top face (the pads, 18.5 mm
# tall about the TCP, on its upper 9 mm).
FROM_ABOVE = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
LEFT_GRIP = np.array([0.0, 0.0, 0.025])
# Right: level, pointing +y, fingers closing along x; TCP 11 mm below the cube's centre (the
# pads from 2 to 20 mm below it), clear of left's fingers above.
FROM_SIDE = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
RIGHT_GRIP = np.array([0.0, 0.0, -0.011])
LEVEL = np.array([0.0, 0.15, 0.1, -2.4, 1.6, 1.6, -1.77])  # right's joints near FROM_SIDE
APPROACH = 0.12  # m: how far off each grasp the hand starts and retreats
TIMEOUT = 120.0  # s a process waits for the other at the barrier


class Arm:
    """One arm's robot and Hand, addressed with world-frame positions."""

    def __init__(self, name: str, host: str) -> None:
        self.name, self.base = name, BASE[name]
        self.robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
        self.gripper = pylibfranka.Gripper(host)
        self.robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
        self.robot.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 2000])

    def turn_to(self, tcp, rotation, seed=READY) -> None:
        """A joint motion putting the TCP at world position `tcp`, turned `rotation`, the arm
        posed like `seed`."""
        move_joints(self.robot, solve_ik(np.asarray(tcp) - self.base, seed, rotation))

    def line_to(self, tcp, speed: float = 0.1) -> None:
        """A straight Cartesian motion of the TCP to world position `tcp`, its orientation kept:
        no sideways jerk or tilt that could slide a held cube between the fingers."""
        control = self.robot.start_cartesian_pose_control(pylibfranka.ControllerMode.JointImpedance)
        state, _ = control.readOnce()
        pose = np.array(state.O_T_EE_c)  # column-major: the position is [12:15]
        start, delta = pose[12:15].copy(), np.asarray(tcp) - self.base - pose[12:15]
        duration = max(0.5, 1.875 * np.linalg.norm(delta) / speed)  # peak speed = speed
        t = 0.0
        while True:
            state, period = control.readOnce()
            t += period.to_sec()
            s = min(t / duration, 1.0)
            pose[12:15] = start + delta * (10 * s**3 - 15 * s**4 + 6 * s**5)
            command = pylibfranka.CartesianPose(pose.tolist())
            command.motion_finished = t >= duration + 0.02
            control.writeOnce(command)
            if command.motion_finished:
                break

    def say(self, text: str) -> None:
        print(f"{self.name}: {text}", flush=True)


def left(host: str, barrier: threading.Barrier) -> None:
    arm = Arm("left", host)
    arm.gripper.homing()
    above = CUBE + LEFT_GRIP + [0.0, 0.0, APPROACH]
    arm.turn_to(above, FROM_ABOVE)
    arm.line_to(CUBE + LEFT_GRIP)
    if not arm.gripper.grasp(CUBE_SIZE, SPEED, GRASP_FORCE):
        sys.exit("left: the grasp missed the cube")
    arm.line_to(above)
    arm.line_to(HANDOVER + LEFT_GRIP)
    arm.say("offering the cube")
    barrier.wait(TIMEOUT)  # offered: right may come in
    barrier.wait(TIMEOUT)  # taken: right holds it
    arm.gripper.move(0.08, SPEED)
    arm.line_to(HANDOVER + LEFT_GRIP + [0.0, 0.0, APPROACH])
    arm.say("released the cube")
    barrier.wait(TIMEOUT)  # released: right may carry it away
    move_joints(arm.robot, READY)


def right(host: str, barrier: threading.Barrier) -> None:
    arm = Arm("right", host)
    arm.gripper.homing()
    back = [0.0, -APPROACH, 0.0]
    arm.turn_to(HANDOVER + RIGHT_GRIP + back, FROM_SIDE, LEVEL)
    barrier.wait(TIMEOUT)  # offered
    arm.line_to(HANDOVER + RIGHT_GRIP)
    if not arm.gripper.grasp(CUBE_SIZE, SPEED, GRASP_FORCE):
        sys.exit("right: the grasp missed the cube")
    barrier.wait(TIMEOUT)  # taken
    barrier.wait(TIMEOUT)  # released
    arm.line_to(HANDOVER + RIGHT_GRIP + back)
    held = arm.gripper.read_once()
    arm.say(f"holding the cube: width {held.width:.4f} m, is_grasped {held.is_grasped}")


def _run(role, host: str, barrier: threading.Barrier) -> None:
    """A role to the end; on any failure, break the barrier so that the other stops too."""
    try:
        role(host, barrier)
    except BaseException:
        barrier.abort()
        raise


def main(left_host: str, right_host: str) -> int:
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(2)
    arms = [context.Process(target=_run, args=(role, host, barrier), name=role.__name__)
            for role, host in ((left, left_host), (right, right_host))]
    for process in arms:
        process.start()
    for process in arms:
        process.join()
    failed = [p.name for p in arms if p.exitcode != 0]
    if failed:
        print("failed:", ", ".join(failed), file=sys.stderr)
        return 1
    print("handed over: the cube is in the right Hand")
    return 0


if __name__ == "__main__":
    sys.exit(main(*(sys.argv[1:3] if len(sys.argv) > 2 else ("127.0.0.11", "127.0.0.12"))))
