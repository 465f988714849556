"""Measures the command link like libfranka's communication_test: zero torques for a while,
then the success-rate statistics the robot reported.

python communication_test.py HOST [CYCLES]
"""

import sys

import pylibfranka


def main(host: str, cycles: int = 5000) -> dict:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    control = robot.start_torque_control()
    rates, lost, previous_ms, count = [], 0, None, 0
    while True:
        state, _ = control.readOnce()
        ms = round(state.time.to_sec() * 1000)
        if previous_ms is not None and ms - previous_ms > 1:
            lost += ms - previous_ms - 1  # states this client never saw
        previous_ms = ms
        rates.append(state.control_command_success_rate)
        count += 1
        command = pylibfranka.Torques([0.0] * 7)
        if count >= cycles:
            command.motion_finished = True
            control.writeOnce(command)
            break
        control.writeOnce(command)
    stats = {
        "cycles": count,
        "states_missed_by_client": lost,
        "avg_success_rate": sum(rates) / len(rates),
        "min_success_rate": min(rates[100:] or rates),
        "final_success_rate": rates[-1],
    }
    print("#" * 60)
    for key, value in stats.items():
        print(f"{key}: {value}")
    print("#" * 60)
    return stats


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1",
         int(sys.argv[2]) if len(sys.argv) > 2 else 5000)
