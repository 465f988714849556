"""The mobile base, served on its own address as a robot of its own (as on a real mobile duo).

Its FCI endpoints (TCP 1337 + UDP) are an arm's, with the base's core behind them
(robot/mobile_base.py); it has no Hand, and its control API answers /health and /state only.
What it shares with the arms (the cycle thread, the lock, the driver) is FrankaSim's.
"""

from __future__ import annotations

import logging
import threading

from franka_sim.control.errors import NotFound
from franka_sim.robot.cycle import Replies
from franka_sim.robot.mobile_base import BaseCore
from franka_sim.robot.session import Session, robot_session
from franka_sim.server.control_ops import mode_name, refuse_if_failed
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.robot_endpoint import RobotEndpoint
from franka_sim.server.robot_server import AddressInUse, RobotServer
from franka_sim.server.udp_endpoint import UdpEndpoint

log = logging.getLogger(__name__)

__all__ = ["AddressInUse", "BaseServer"]


class BaseOps:
    """The base's control operations: what it is doing, nothing that changes the world."""

    def __init__(self, core: BaseCore, lock: threading.Lock, clock: str, client_connected,
                 worker: CycleThread) -> None:
        self.core, self.lock, self.clock = core, lock, clock
        self.client_connected, self.worker = client_connected, worker

    def health(self) -> dict:
        refuse_if_failed(self.worker)
        core = self.core
        return {"ready": True, "mobile_base": True, "clock": self.clock,
                "cycle": core.message_id, "client_connected": self.client_connected(),
                "robot_mode": mode_name(core.robot_mode)}

    async def state(self) -> dict:
        with self.lock:
            core, drive = self.core, self.core.drive
            return {"q": list(drive.q), "dq": list(drive.dq),
                    "pose": {"x": drive.x, "y": drive.y, "yaw": drive.yaw},
                    "twist": {"vx": drive.vx, "vy": drive.vy, "wz": drive.wz},
                    "robot_mode": mode_name(core.robot_mode), "cycle": core.message_id}

    async def _none(self, *args, **kwargs):
        raise NotFound("the mobile base's control API serves /health and /state only")

    reset = bodies = pose = set_pose = push = _none


class BaseServer(RobotServer):
    """The base's endpoints on `host`; `on_command(command)` hands the driver its commands."""

    def __init__(self, core: BaseCore, host: str, config, *, driver: CycleDriver,
                 worker: CycleThread, lock: threading.Lock, on_command) -> None:
        self.core, self.host, self.config = core, host, config
        self.driver, self.lock = driver, lock
        self.name = self.label = "mobile base"
        self.udp = UdpEndpoint(on_command)
        self.robot = RobotEndpoint(self._make_session, self._on_handshake, self._on_disconnect,
                                   defer_replies=driver.after_next_state, lock=lock,
                                   replaceable=self._client_silent,
                                   on_request=driver.client_event)
        self.control = BaseOps(core, lock, config.clock.value,
                               lambda: self.robot.active is not None, worker)
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

