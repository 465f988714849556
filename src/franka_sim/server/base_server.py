"""The mobile base, served on its own address as a robot of its own (as on a real mobile duo).

Its FCI endpoints (TCP 1337 + UDP) are an arm's, with the base's core behind them
(robot/mobile_base.py); it has no Hand, and its control API serves the rows of
operations/table.py the base has (/health, /state, /faults; operations/base.py).
What it shares with the arms (the cycle thread, the lock, the driver) is FrankaSim's.
"""

from __future__ import annotations

import logging
import threading

from franka_sim.operations.base import BaseOps
from franka_sim.robot.cycle import Replies
from franka_sim.robot.mobile_base import BaseCore
from franka_sim.robot.session import Session, robot_session
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.robot_endpoint import RobotEndpoint
from franka_sim.server.robot_server import AddressInUse, RobotServer
from franka_sim.server.udp_endpoint import UdpEndpoint

log = logging.getLogger(__name__)

__all__ = ["AddressInUse", "BaseServer"]


class BaseServer(RobotServer):
    """The base's endpoints on `host`, robot `index` of the world; `on_command(command)` hands
    the driver its commands; `faults`: the world's NetworkFaults (its API sets the base's)."""

    def __init__(self, core: BaseCore, host: str, config, *, index: int, driver: CycleDriver,
                 worker: CycleThread, lock: threading.Lock, on_command, faults=None) -> None:
        self.core, self.host, self.config = core, host, config
        self.driver, self.lock = driver, lock
        self.name = self.label = "mobile base"
        self.udp = UdpEndpoint(on_command)
        self.robot = RobotEndpoint(self._make_session, self._on_handshake, self._on_disconnect,
                                   defer_replies=driver.after_next_state, lock=lock,
                                   replaceable=self._client_silent,
                                   on_request=driver.client_event)
        self.control = BaseOps(core, lock, config.clock.value,
                               lambda: self.robot.active is not None, worker,
                               robot_index=index, faults=faults)
        self._control_api = None
        self.gripper = None

    def describe(self) -> str:
        config = self.config
        return "serving on {}:{} (mobile base; {}".format(
            self.host, config.robot_port,
            f"control API on {config.control_port}" if config.control_port
            else "no control API")

    def hand_state_wanted(self) -> bool:
        return False

    def deliver(self, replies: Replies) -> None:
        for reply in replies.robot:
            self.robot.send(reply)

    def _make_session(self) -> Session:
        self.driver.resume()
        return robot_session(self.core)

