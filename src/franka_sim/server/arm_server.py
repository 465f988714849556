"""One arm of the world, served on its own address exactly as a lone robot is served.

Everything a robot has of its own lives here: its robot core (modes, errors, reflexes, Set*
settings, success rate), its Hand, its FCI endpoints (TCP 1337 + UDP) and the Hand's (1338),
and its control API. What the arms share (the cycle thread and its world, the lock, the
driver that paces the world's cycles) is FrankaSim's (server/sim.py), which wires them.
"""

from __future__ import annotations

import logging
import threading

from franka_sim.assembly import ArmParts
from franka_sim.operations.arm import ControlOps
from franka_sim.robot.cycle import Replies
from franka_sim.robot.session import Session
from franka_sim.server.cycle_driver import CycleDriver
from franka_sim.server.cycle_thread import CycleThread
from franka_sim.server.gripper_endpoint import GripperEndpoint
from franka_sim.server.robot_endpoint import RobotEndpoint
from franka_sim.server.robot_server import RobotServer
from franka_sim.server.udp_endpoint import UdpEndpoint

log = logging.getLogger(__name__)


class ArmServer(RobotServer):
    """Arm `index` of the world (its parts: assembly.ArmParts, named and addressed by their
    spec). `driver` is the world's (its clock serves every arm); `on_command(command)` hands it
    this arm's commands; `faults`: the world's NetworkFaults (its control API sets this arm's)."""

    def __init__(self, parts: ArmParts, index: int, *, driver: CycleDriver, worker: CycleThread,
                 lock: threading.Lock, on_command, faults=None) -> None:
        self.parts, self.spec, self.index, self.config = parts, parts.spec, index, parts.config
        self.driver, self.lock = driver, lock
        self.core, self.gripper = parts.core, parts.gripper
        self.gripper_endpoint = GripperEndpoint(
            self._make_gripper_session, self._on_gripper_disconnect, lock=lock,
            on_request=driver.client_event)
        self.udp = UdpEndpoint(on_command)
        self.robot = RobotEndpoint(self._make_session, self._on_handshake, self._on_disconnect,
                                   defer_replies=driver.after_next_state, lock=lock,
                                   replaceable=self._client_silent,
                                   on_request=driver.client_event)
        self.control = ControlOps(
            core=self.core, gripper=self.gripper, driver=driver, worker=worker, lock=lock,
            description=parts.description, q0=parts.q0, clock=self.config.clock.value,
            client_connected=lambda: self.robot.active is not None, arm=self.spec.name,
            arm_index=index, faults=faults)
        self._control_api = None  # the HTTP server, while it serves (server/control_api.py)
        self.label = f"arm {self.spec.name}"

    @property
    def host(self) -> str:
        return self.spec.host

    def describe(self) -> str:
        """"serving on HOST:PORT (arm NAME; Hand; control API": the log line's own part."""
        config = self.config
        return "serving on {}:{} (arm {}; {}; {}".format(
            self.host, config.robot_port, self.spec.name,
            f"Franka Hand on {config.gripper_port}" if self.gripper is not None
            else "no gripper",
            f"control API on {config.control_port}" if config.control_port
            else "no control API")

    # -- the cycle -------------------------------------------------------------------------------
    def hand_state_wanted(self) -> bool:
        """A Hand client takes GripperStates (its handshake said where)."""
        return self.gripper_endpoint.state_target is not None

    def deliver(self, replies: Replies) -> None:
        """A cycle's replies, on the loop, once its state has left."""
        for reply in replies.robot:
            self.robot.send(reply)
        for reply in replies.hand:
            self.gripper_endpoint.send(reply)
        if replies.hand_state is not None:
            self.gripper_endpoint.send_state(replies.hand_state)

    # -- the endpoints' callbacks ----------------------------------------------------------------
    def _make_session(self) -> Session:
        self.driver.resume()  # a paused clock starts again for the newcomer
        return self.parts.robot_session()

    def _make_gripper_session(self) -> Session:
        self.driver.resume()
        return self.parts.gripper_session()

    def _on_gripper_disconnect(self) -> None:
        self.gripper.client_gone()
        self.driver.client_event()
