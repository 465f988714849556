"""Low-rate joint targets through pylibfranka's AsyncPositionControlHandler.

The robot's own generator moves toward each target under the configured maximum velocities;
the client only sets targets and polls feedback. python async_position_control.py HOST
"""

import sys
import time

import pylibfranka

MAX_VELOCITIES = [0.655, 0.655, 0.655, 0.655, 1.315, 1.315, 1.315]
GOAL_TOLERANCE = 0.01  # rad


def main(host: str) -> list:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([20.0] * 7, [20.0] * 7, [20.0] * 6, [20.0] * 6)
    start = list(robot.read_once().q)
    config = pylibfranka.AsyncPositionControlHandler.Configuration(MAX_VELOCITIES, GOAL_TOLERANCE)
    result = pylibfranka.AsyncPositionControlHandler.configure(robot, config)
    if result.error_message:
        raise RuntimeError(result.error_message)
    handler = result.handler
    reached = []
    for offset in (0.2, 0.0):
        target = [q + offset for q in start]
        command = handler.set_joint_position_target(
            pylibfranka.AsyncPositionControlHandler.JointPositionTarget(target))
        if not command.was_successful:
            raise RuntimeError(command.error_message)
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            feedback = handler.get_target_feedback()
            if feedback.status.name == "kTargetReached":
                break
            if feedback.error_message:
                raise RuntimeError(feedback.error_message)
            time.sleep(0.01)
        else:
            handler.stop_control()
            raise RuntimeError(f"target {target} not reached within 30 s "
                               f"({feedback.status.name})")
        state = robot.read_once()
        reached.append([round(q, 4) for q in state.q])
        print("reached", reached[-1], feedback.status)
    handler.stop_control()
    return reached


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1")
