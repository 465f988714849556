"""A reply the world made for one client never reaches the next.

A Move's final status and a Hand action's are made by the cycle and written later, on the
loop. A client that hung up meanwhile, and a newcomer already connected, must not get it: its
command ids start again, so libfranka would take the stale status for its own request (a
Gripper.move that 'succeeded' in 10 ms, its fingers not moved). The world's moment is stamped
on the replies; this test puts the whole race in order by hand, so it is the same every run.
"""

from __future__ import annotations

import socket
import struct
import time

import pytest
from support.embedded import CONNECT, GRIPPER, ROBOT, on_loop, serving

CONNECT_REPLY_SIZE = {ROBOT: 15, GRIPPER: 14}
# A final status as each service writes it: a Move's (robot: command 3) and a Hand Move's
# (gripper: command 3), for a command id the next client will use too.
STALE = {ROBOT: struct.pack("<IIIB", 3, 1, 13, 0), GRIPPER: struct.pack("<HIIH", 3, 1, 12, 0)}
FRESH = {ROBOT: struct.pack("<IIIB", 3, 2, 13, 0), GRIPPER: struct.pack("<HIIH", 3, 2, 12, 0)}


class _Replies:
    def __init__(self, port: int, reply: bytes) -> None:
        self.robot = [reply] if port == ROBOT else []
        self.tools = [([reply], None)] if port == GRIPPER else []


def _connected(host: str, port: int) -> socket.socket:
    s = socket.create_connection((host, port), timeout=20, source_address=(host, 0))
    s.sendall(CONNECT[port])
    reply = b""
    while len(reply) < CONNECT_REPLY_SIZE[port]:
        reply += s.recv(CONNECT_REPLY_SIZE[port] - len(reply))
    return s


@pytest.mark.parametrize("port", [ROBOT, GRIPPER])
def test_a_reply_made_before_its_client_left_does_not_reach_the_next(port):
    with serving() as sim:
        robot = sim.robots[0]
        endpoint = sim.fci if port == ROBOT else sim.tool_endpoint
        first = _connected(sim.config.host, port)
        made_for_first = on_loop(sim, robot.clients)  # the world made a reply then
        first.close()
        deadline = time.monotonic() + 20
        while endpoint.active is not None and time.monotonic() < deadline:
            time.sleep(0.01)
        second = _connected(sim.config.host, port)
        on_loop(sim, lambda: robot.deliver(_Replies(port, STALE[port]), made_for_first))
        on_loop(sim, lambda: robot.deliver(_Replies(port, FRESH[port]), robot.clients()))
        second.settimeout(20)
        got = second.recv(len(FRESH[port]))
        second.close()
    assert got == FRESH[port]
