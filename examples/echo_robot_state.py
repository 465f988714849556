"""Prints a few robot states, as libfranka's echo_robot_state does.

python echo_robot_state.py HOST [COUNT]
"""

import sys

import pylibfranka


def main(host: str, count: int = 10) -> None:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    for _ in range(count):
        state = robot.read_once()
        print(
            f"time={state.time.to_sec():.3f}s mode={state.robot_mode.name} "
            f"q={[round(v, 4) for v in state.q]} tau_J={[round(v, 3) for v in state.tau_J]} "
            f"O_T_EE.t={[round(v, 4) for v in state.O_T_EE[12:15]]} "
            f"success_rate={state.control_command_success_rate}"
        )


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         int(sys.argv[2]) if len(sys.argv) > 2 else 10)
