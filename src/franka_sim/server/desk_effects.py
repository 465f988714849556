"""What the Desk leaves the robot in, applied: the FCI's port open or closed, the tool's
service answering or not (end-effector power), the arm held or free.

As on the robot, an inactive FCI is a closed port 1337 (libfranka: "Connection to FCI
refused"), and its client, if any, is cut off; an unpowered end effector's service stops
answering the same way. The arm's hold is an operation (ArmOps.desk_arm): a job
between two cycles, recorded, so replay sets it at the same cycle.
"""

from __future__ import annotations

import logging

log = logging.getLogger(__name__)


class DeskEffects:
    def __init__(self, robot) -> None:
        self.robot = robot  # server/robot_server.py RobotServer (an arm's)
        self.fci_open = False
        self.tool_open = False
        self.homings = 0  # the Desk's gripper homings started

    async def apply(self) -> None:
        robot, desk = self.robot, self.robot.control.desk_state
        if desk.fci_active != self.fci_open:
            if desk.fci_active:
                await robot.fci.start(robot.host, robot.config.robot_port)
            else:
                await robot.fci.stop()
            self.fci_open = desk.fci_active
            log.info("FCI %s", "active" if self.fci_open else
                     "inactive (port %d refuses connections)" % robot.config.robot_port)
        tool = robot.tool_endpoint
        if tool is not None and desk.end_effector_powered != self.tool_open:
            if desk.end_effector_powered:
                await tool.start(robot.host, robot.tool_port)
            else:
                await tool.stop()
            self.tool_open = desk.end_effector_powered
            log.info("end effector %s",
                     "powered" if self.tool_open else "unpowered (its service does not answer)")
        if robot.core.status.held == desk.arm_ready:
            await robot.control.desk_arm()
        while self.homings < desk.gripper_homings:
            self.homings += 1
            await robot.control.home_gripper()  # (ControlError: the Hand busy by now)

    def homing_refused(self) -> str | None:
        """Why a homing the Desk was just asked for cannot start (no Hand on this arm, or an
        action under way), said before anything is applied; None: it can. A refused one is
        dropped, not started later."""
        desk = self.robot.control.desk_state
        if self.homings == desk.gripper_homings:
            return None
        hand = self.robot.control.hand
        why = ("no Franka Hand on this arm (its tool: --tool hand puts one there)" if hand is None
               else "the Hand is busy: an action is under way" if hand.busy else None)
        if why is not None:
            self.homings = desk.gripper_homings
        return why
