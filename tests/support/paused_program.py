"""A lockstep client's program with pauses between its steps, printing the time of every state
it read (libfranka's `time` is the state's message_id, in ms) as one JSON list:

    python tests/support/paused_program.py HOST [--slow-start]

Three short joint motions with pauses of 50 ms and 500 ms, a Hand move and another pause, and
a last motion. `--slow-start`: the client takes 20 ms over each motion's first command, as a
program that sets up its controller on the first state does.
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np
import pylibfranka

PAUSES = (0.05, 0.5, 0.05)


def motion(robot, times: list, slow_start: bool, turn: float) -> None:
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    times.append(state.time.to_sec())
    q0, t = np.array(state.q_d), 0.0
    if slow_start:
        time.sleep(0.02)
    while True:
        state, period = control.readOnce()
        times.append(state.time.to_sec())
        t += period.to_sec()
        s = 0.5 * (1 - math.cos(math.pi * min(t / 0.2, 1.0)))
        command = pylibfranka.JointPositions((q0 + s * turn).tolist())
        command.motion_finished = t >= 0.2
        control.writeOnce(command)
        if command.motion_finished:
            break
    times.append(robot.read_once().time.to_sec())


def main(host: str, slow_start: bool) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    gripper = pylibfranka.Gripper(host)
    times = [robot.read_once().time.to_sec()]
    for k, pause in enumerate(PAUSES):
        motion(robot, times, slow_start, 0.05 * (-1) ** k)
        time.sleep(pause)
    gripper.move(0.03, 0.1)
    times.append(robot.read_once().time.to_sec())
    time.sleep(0.5)
    motion(robot, times, slow_start, 0.05)
    print(json.dumps([round(t * 1000) for t in times]))


if __name__ == "__main__":
    main(sys.argv[1], "--slow-start" in sys.argv[2:])
