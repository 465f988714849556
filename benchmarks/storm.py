"""A storm of connection attempts on the robot's port while a client runs a 1 kHz torque loop.

Another process tries to connect to 1337 at --rate attempts per second for --seconds; each
attempt waits for the server to close it (one client at a time: the newcomer is refused). The
client's torque loop runs from before the storm to after it. Printed: the success rate the
robot reported to the client during the storm (target ≥ 0.999), its state intervals then, and
the attempts made, refused by the server, and failed otherwise (not accepted in time, reset).

python benchmarks/storm.py [--rate 1000] [--seconds 5] [--host 127.0.0.203]
"""

from __future__ import annotations

import argparse
import multiprocessing
import socket
import time

import numpy as np
import pylibfranka

from _common import verdict
from _torque_loop import percentiles_ms, torque_loop
from franka_sim.testing import ServerProcess

PRIVATE_HOST = "127.0.0.203"
MARGIN = 2.0  # s of the loop before and after the storm


def _storm(host: str, rate: float, seconds: float, start_at: float, counts) -> None:
    """Attempts at `rate` per second from wall time `start_at` (perf_counter) for `seconds`."""
    while time.perf_counter() < start_at:
        time.sleep(0.001)
    made = refused = failed = 0
    period, end = 1.0 / rate, start_at + seconds
    next_at = start_at
    while next_at < end:
        made += 1
        try:
            with socket.create_connection((host, 1337), timeout=1.0,
                                          source_address=(host, 0)) as s:
                s.settimeout(1.0)
                if s.recv(1) == b"":
                    refused += 1
                else:
                    failed += 1
        except OSError:  # refused by the kernel, reset, timed out
            failed += 1
        next_at += period
        delay = next_at - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
    counts[:] = [made, refused, failed, time.perf_counter() - start_at]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=1000.0, help="attempts per second")
    parser.add_argument("--seconds", type=float, default=5.0, help="how long the storm lasts")
    parser.add_argument("--host", default=PRIVATE_HOST)
    args = parser.parse_args()
    server = ServerProcess(args.host)
    server.wait_ready()
    counts = multiprocessing.Array("d", 4)
    try:
        robot = pylibfranka.Robot(args.host, pylibfranka.RealtimeConfig.kIgnore)
        start_at = time.perf_counter() + MARGIN + 1.0  # the motion has started by then
        storm = multiprocessing.Process(
            target=_storm, args=(args.host, args.rate, args.seconds, start_at, counts))
        storm.start()
        run = torque_loop(robot, args.seconds + 2 * MARGIN + 1.0)
        storm.join(60)
        del robot
    finally:
        server.stop()
    made, refused, failed, took = counts[:]
    during = (run["stamps"] >= start_at) & (run["stamps"] <= start_at + took)
    rates = run["rates"][during]
    print(f"storm: {made:.0f} attempts in {took:.1f} s ({made / max(took, 1e-9):.0f}/s): "
          f"{refused:.0f} refused by the server, {failed:.0f} failed otherwise")
    print(f"client during the storm: {int(during.sum())} states, "
          f"{percentiles_ms(run['intervals'][during])}")
    mean = float(np.mean(rates)) if len(rates) else 0.0
    print(f"success rate during the storm (mean / min) {mean:.5f} / "
          f"{float(np.min(rates)) if len(rates) else 0.0:.4f}   target ≥ 0.999  "
          f"{verdict(mean >= 0.999)}")


if __name__ == "__main__":
    main()
