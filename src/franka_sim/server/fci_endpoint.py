"""The TCP side of the robot (port 1337): one client at a time, as on the real FCI.

The FR3 allows a single FCI connection; a second client is closed at once (see single_client.py
and docs/deviations.md), unless the first has fallen silent mid-motion (ArmCore.client_silent).
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import Callable

from franka_sim.robot.session import Handshake, Session
from franka_sim.server.single_client import SingleClientEndpoint


class FciEndpoint(SingleClientEndpoint):
    def __init__(self, make_session: Callable[[], Session],
                 on_handshake: Callable[[str, Handshake], None],
                 on_disconnect: Callable[[], None],
                 defer_replies: Callable[[Callable[[], None]], bool] = lambda deliver: False,
                 lock: AbstractContextManager | None = None,
                 replaceable: Callable[[], bool] = lambda: False,
                 on_request: Callable[[bool], None] = lambda disturbing: None,
                 taps=None) -> None:
        super().__init__("FCI", make_session, on_handshake, on_disconnect, defer_replies, lock,
                         replaceable, on_request, taps=taps)
