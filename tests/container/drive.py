"""pylibfranka against a served image: read a state, a short joint motion, the Hand's homing.

    python tests/container/drive.py HOST

in this process (`drive`), or as a process of its own (`drive_apart`: so that a client left
hanging by a network path is bounded, and so that it may run in another network namespace).
Fails with "container test: drive failed: why" on stderr and exit status 1.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from docker_cli import StepFailed, last_line  # noqa: E402


def drive(host: str) -> float:
    """Seconds taken by a pylibfranka session: read a state, a 0.5 s joint motion on the
    last joint, the Hand's homing."""
    try:
        import pylibfranka
    except ImportError:
        raise StepFailed("drive", "pylibfranka is not installed (the test extra)") from None
    start = time.monotonic()
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
        if robot.read_once().robot_mode != pylibfranka.RobotMode.Idle:
            raise StepFailed("drive", "the robot is not Idle after connecting")
        control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
        state, _ = control.readOnce()
        q0, t, duration = list(state.q_d), 0.0, 0.5
        while True:
            state, period = control.readOnce()
            t += period.to_sec()
            q = list(q0)
            q[6] += 0.05 * (1 - math.cos(math.pi * min(t / duration, 1.0))) / 2
            command = pylibfranka.JointPositions(q)
            command.motion_finished = t >= duration
            control.writeOnce(command)
            if command.motion_finished:
                break
        moved = robot.read_once().q[6] - q0[6]
        if abs(moved - 0.05) > 0.01:
            raise StepFailed("drive", f"joint 7 moved {moved:.4f} rad, not 0.05")
        gripper = pylibfranka.Gripper(host)
        if not gripper.homing():
            raise StepFailed("drive", "the Hand's homing reported failure")
    except StepFailed:
        raise
    except Exception as exc:  # noqa: BLE001 - whatever libfranka raised, in one line
        raise StepFailed("drive", f"{type(exc).__name__}: {exc}") from None
    finally:  # libfranka left this thread under SCHED_FIFO 99: not what docker runs under
        os.sched_setscheduler(0, policy, param)
    return time.monotonic() - start


def drive_apart(host: str, step: str, prefix: tuple[str, ...] = (), timeout: float = 60.0) -> float:
    """`drive(host)` in a process of its own, started through `prefix` (e.g. `ip netns exec
    NS`): its seconds, or StepFailed(`step`). `timeout` bounds a client left hanging (a
    session takes ~2 s), so that a path that drops its answers fails instead of blocking."""
    start = time.monotonic()
    try:
        done = subprocess.run([*prefix, sys.executable, str(Path(__file__)), host],
                              capture_output=True, text=True, timeout=timeout,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        raise StepFailed(step, f"pylibfranka hung: no end after {timeout:.0f} s") from None
    if done.returncode != 0:
        why = last_line(done.stderr + done.stdout).removeprefix("container test: drive failed: ")
        raise StepFailed(step, why)
    return time.monotonic() - start


if __name__ == "__main__":
    try:
        print(f"{drive(sys.argv[1]):.2f}")
    except StepFailed as exc:
        print(f"container test: {exc}", file=sys.stderr)
        sys.exit(1)
