"""The machine's bound under any lockstep server: two processes handing one datagram back and
forth on loopback, each doing nothing else.

A lockstep cycle is one such round trip (the server's state out, the client's command back) plus
both sides' work, so no server can run more cycles per wall second than this does round trips.
Prints the round trip in µs (median, and the mean that a long run pays), with the answering side
blocking in recv as libfranka does, and with it reading without sleeping (as franka-sim's cycle
thread does for a moment after each state), and the CPU both processes used per round trip.

python benchmarks/pingpong.py [--trips 20000]
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import sys
import time

HOST = "127.0.0.205"


def echo(port: int, trips: int, spin: bool) -> None:
    """The other process: answer every datagram at once."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((HOST, port + 1))
    sock.setblocking(not spin)
    peer = (HOST, port)
    sock.sendto(b"ready", peer)
    for _ in range(trips):
        while True:
            try:
                data = sock.recv(2048)
                break
            except BlockingIOError:
                continue
        sock.sendto(data, peer)
    os._exit(0)


def measure(trips: int, spin: bool) -> tuple[float, float, float]:
    """(median µs, mean µs, CPU µs of both processes) per round trip."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind((HOST, 0))
    port = sock.getsockname()[1]
    pid = os.fork()
    if pid == 0:
        sock.close()
        echo(port, trips, spin)
    sock.recv(16)  # the echo is ready
    payload, peer = b"x" * 1200, (HOST, port + 1)
    times = []
    c0, t0 = os.times(), time.perf_counter()
    for _ in range(trips):
        start = time.perf_counter()
        sock.sendto(payload, peer)
        sock.recv(2048)
        times.append(time.perf_counter() - start)
    wall = time.perf_counter() - t0
    os.waitpid(pid, 0)
    c1 = os.times()
    cpu = (c1.user - c0.user) + (c1.system - c0.system) + \
        (c1.children_user - c0.children_user) + (c1.children_system - c0.children_system)
    sock.close()
    return 1e6 * statistics.median(times), 1e6 * wall / trips, 1e6 * cpu / trips


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trips", type=int, default=20000)
    args = parser.parse_args()
    print(f"pingpong: {args.trips} round trips of a 1200-byte datagram between two Python "
          f"processes on {HOST} ({os.cpu_count()} CPUs)")
    for spin, what in ((False, "answer blocking in recv"), (True, "answer read without sleeping")):
        median, mean, cpu = measure(args.trips, spin)
        print(f"  {what:<30} round trip median {median:6.1f} µs, mean {mean:6.1f} µs "
              f"({1e6 / mean / 1000:5.1f}× real time at 1 ms a trip); CPU {cpu:6.1f} µs")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
