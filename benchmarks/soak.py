"""A long run: a pylibfranka torque loop, the Hand now and then, a reconnect every minute.

Each minute the client connects anew (a new pylibfranka.Robot), runs a torque loop for the rest
of the minute, and disconnects; meanwhile another process connects a pylibfranka.Gripper each
minute and homes or moves it every 10 s. Printed per minute: the success rate the robot reports
(mean and min after the first 200 cycles), the state interval percentiles as the client sees
them, and the server's RSS and open file descriptors (after the minute's client left). At the
end: whether the targets hold (success ≥ 0.999 each minute, RSS drift < 2 MiB from the first
minute to the last, open fds flat (less its established client connections)).

python benchmarks/soak.py --minutes 10 [--host 127.0.0.202]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import time

import pylibfranka

from _common import memory_mib, verdict
from _torque_loop import percentiles_ms, torque_loop
from franka_sim.testing import ServerProcess

PRIVATE_HOST = "127.0.0.202"
HAND_PERIOD = 10.0  # s between Hand actions


def _hand(host: str, minutes: int) -> None:
    """The Hand's client: a new connection each minute, an action every HAND_PERIOD."""
    for _ in range(minutes):
        gripper = pylibfranka.Gripper(host)
        minute_end = time.monotonic() + 60
        k = 0
        while time.monotonic() + HAND_PERIOD < minute_end:
            started = time.monotonic()
            if k % 3 == 0:
                gripper.homing()
            else:
                gripper.move(0.02 + 0.02 * (k % 3), 0.1)
            k += 1
            time.sleep(max(0.0, HAND_PERIOD - (time.monotonic() - started)))
        del gripper
        time.sleep(max(0.0, minute_end - time.monotonic()))


def _open_fds(pid: int) -> int:
    """The server's open fds, less its established TCP connections: the Hand's client comes
    and goes on its own minute, so whether its connection is open when this reads is timing."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    established = 0
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as f:
                next(f)
                for line in f:
                    fields = line.split()
                    established += fields[3] == "01" and fields[9] in inodes
        except OSError:
            pass
    return len(os.listdir(f"/proc/{pid}/fd")) - established


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=int, default=10)
    parser.add_argument("--host", default=PRIVATE_HOST)
    args = parser.parse_args()
    server = ServerProcess(args.host)
    server.wait_ready()
    hand = multiprocessing.Process(target=_hand, args=(args.host, args.minutes), daemon=True)
    rows = []
    try:
        hand.start()
        for minute in range(1, args.minutes + 1):
            robot = pylibfranka.Robot(args.host, pylibfranka.RealtimeConfig.kIgnore)
            run = torque_loop(robot, 58.0)  # + connecting and the motion's start ≈ a minute
            del robot
            time.sleep(0.5)  # the disconnect is served
            rates = run["rates"][200:]
            rss, _ = memory_mib(server.pid)
            fds = _open_fds(server.pid)
            rows.append((rates.mean(), rss, fds))
            print(f"minute {minute:3d}: success {rates.mean():.5f} (min {rates.min():.4f})  "
                  f"{percentiles_ms(run['intervals'][1:])}  RSS {rss:.1f} MiB  fds {fds}",
                  flush=True)
        hand.join(120)
        hand_ok = hand.exitcode == 0
    finally:
        hand.kill()
        server.stop()
    success = min(r[0] for r in rows)
    drift = rows[-1][1] - rows[0][1]
    fds = [r[2] for r in rows]
    print(f"worst minute's success rate {success:.5f}   target ≥ 0.999  {verdict(success >= 0.999)}")
    print(f"RSS drift, first to last minute {drift:+.2f} MiB   target < 2  "
          f"{verdict(abs(drift) < 2)}")
    print(f"open fds per minute {min(fds)}..{max(fds)}   target flat  "
          f"{verdict(max(fds) == min(fds))}")
    print(f"the Hand's client {'finished every action' if hand_ok else 'FAILED'}  "
          f"{verdict(hand_ok)}")


if __name__ == "__main__":
    main()
