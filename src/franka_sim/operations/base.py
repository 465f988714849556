"""What the mobile base's control API does: what it is doing, and the network faults on its UDP
path (operations/faults.py); nothing that changes the world. Each method is a row of
control/table.py whose kinds include the base; the other rows it answers 404."""

from __future__ import annotations

import threading

from franka_sim.operations.faults import FaultOps
from franka_sim.operations.ports import Jobs
from franka_sim.control.table import Kind
from franka_sim.operations.values import mode_name, refuse_if_failed
from franka_sim.robot.base_core import BaseCore


class BaseOps(FaultOps):
    """The base's operations; it is robot `robot_index` of the world (after the arms)."""

    kind = Kind.BASE

    def __init__(self, core: BaseCore, lock: threading.Lock, clock: str, client_connected,
                 worker: Jobs, *, robot_index: int, faults=None) -> None:
        self.core, self.lock, self.clock = core, lock, clock
        self.client_connected, self.worker = client_connected, worker
        self.robot_index, self.network_faults = robot_index, faults

    def health(self) -> dict:
        refuse_if_failed(self.worker)
        core = self.core
        return {"ready": True, "mobile_base": True, "clock": self.clock,
                "cycle": core.message_id, "client_connected": self.client_connected(),
                "robot_mode": mode_name(core.robot_mode)}

    async def state(self) -> dict:
        # (no job: the base's figures are the core's, read under the lock as a request does)
        with self.lock:
            core, drive = self.core, self.core.drive
            return {"q": list(drive.q), "dq": list(drive.dq),
                    "pose": {"x": drive.x, "y": drive.y, "yaw": drive.yaw},
                    "twist": {"vx": drive.vx, "vy": drive.vy, "wz": drive.wz},
                    "robot_mode": mode_name(core.robot_mode), "cycle": core.message_id}
