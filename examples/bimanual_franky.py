"""Two arms, two franky programs: each picks its object, they lift together, each sets its
object down 10 cm further out and lets go.

The arms stand mirrored about the world's y = 0 plane and so do the objects (left: the 5 cm
cube, right: the 4 x 4 x 12 cm box standing on end), so both programs are one function given
mirrored targets in their own base frames: franky's Ruckig-planned Cartesian motions, its
Gripper's grasp and move. Each arm runs in a process of its own; a multiprocessing Barrier
makes them lift (and leave) together.

Run it against franka-sim serving the two-arm scene:
    franka-sim serve --arm left=127.0.0.11 --arm right=127.0.0.12 --scene dual_arm_table
    python bimanual_franky.py 127.0.0.11 127.0.0.12
"""

from __future__ import annotations

import multiprocessing
import sys
import threading


SIDE = {"left": -1.0, "right": 1.0}  # the sign of y, in the arm's own base frame, of its object
REACH = 0.45, 0.20  # m: x and |y| of the object in its arm's base frame (the scene's 0.45, ±0.15)
OBJECT = {"left": ("cube", 0.05, 0.05), "right": ("box", 0.04, 0.12)}  # name, width, height
MOVE = 0.10  # m: how far out (+x) each object is set down
LIFT = 0.10  # m
GRIP_BELOW_TOP = 0.015  # m: the TCP this far under the object's top, palm clear of it
TIMEOUT = 120.0  # s a process waits for the other at the barrier


def arm_program(name: str, host: str, barrier: threading.Barrier) -> None:
    from franky import Affine, CartesianMotion, Gripper, RealtimeConfig, Robot

    robot = Robot(host, realtime_config=RealtimeConfig.Ignore)
    # At 0.2 the joint accelerations these Cartesian motions need reach ~15 rad/s² at joint 2,
    # past the FR3's 10 (a reflex under --enforce-motion-limits); at 0.1 they stay inside.
    robot.relative_dynamics_factor = 0.1
    gripper = Gripper(host)
    down = robot.current_pose.end_effector_pose.quaternion  # the start pose's: pointing down
    what, width, height = OBJECT[name]

    def go(x: float, z: float) -> None:
        robot.move(CartesianMotion(Affine([x, SIDE[name] * REACH[1], z], down)))

    x, grip = REACH[0], height - GRIP_BELOW_TOP
    gripper.homing()
    go(x, grip + LIFT)
    go(x, grip)
    if not gripper.grasp(width, 0.05, 20.0):
        sys.exit(f"{name}: the grasp missed the {what}")
    barrier.wait(TIMEOUT)  # both hold theirs: lift together
    go(x, grip + LIFT)
    go(x + MOVE, grip + LIFT)
    go(x + MOVE, grip + 0.002)  # let it down from 2 mm
    gripper.move(0.08, 0.05)
    go(x + MOVE, grip + LIFT)
    barrier.wait(TIMEOUT)
    # One write for the whole line: the other arm's process prints to the same stream.
    sys.stdout.write(f"{name}: set the {what} down at x = {x + MOVE:.2f} m\n")
    sys.stdout.flush()


def _run(name: str, host: str, barrier: threading.Barrier) -> None:
    """One arm's program; on any failure, break the barrier so that the other stops too."""
    try:
        arm_program(name, host, barrier)
    except BaseException:
        barrier.abort()
        raise


def main(left_host: str, right_host: str) -> int:
    context = multiprocessing.get_context("spawn")
    barrier = context.Barrier(2)
    arms = [context.Process(target=_run, args=(name, host, barrier), name=name)
            for name, host in (("left", left_host), ("right", right_host))]
    for process in arms:
        process.start()
    for process in arms:
        process.join()
    failed = [p.name for p in arms if p.exitcode != 0]
    if failed:
        print("failed:", ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(*(sys.argv[1:3] if len(sys.argv) > 2 else ("127.0.0.11", "127.0.0.12"))))
