"""The platform floor for stream.py: the simplest possible 1 kHz RobotState sender.

One thread, absolute 1 ms deadlines, time.sleep with 1 µs timer slack, zeroed 1377-byte states
with an increasing message_id; answers one Connect. No physics, no event loop, no other threads.
`python benchmarks/stream.py --reference` runs it in place of franka-sim, so jitter that this
sender shows too comes from the machine (load, VM scheduling), not from franka-sim.

    python benchmarks/reference_sender.py --host 127.0.0.201
"""

from __future__ import annotations

import argparse
import socket
import struct
import sys
import time

from _common import reference_process


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--host", default="127.0.0.201")
    args = ap.parse_args()
    reference_process()
    server = socket.create_server((args.host, 1337), reuse_port=False)
    print(f"reference sender serving on {args.host}:1337", file=sys.stderr, flush=True)
    conn, peer = server.accept()
    _, command_id, _, _, udp_port = struct.unpack("<IIIHH", conn.recv(16))
    conn.sendall(struct.pack("<IIIBH", 0, command_id, 15, 0, 10))
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind((args.host, 0))
    state = bytearray(1377)
    t0, k = time.monotonic(), 0
    while True:
        k += 1
        struct.pack_into("<Q", state, 0, k)
        try:
            udp.sendto(state, (peer[0], udp_port))
        except OSError:  # client gone
            pass
        delay = t0 + k * 1e-3 - time.monotonic()
        if delay > 0:
            time.sleep(delay)


if __name__ == "__main__":
    main()
