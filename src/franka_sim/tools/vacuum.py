"""The vacuum gripper (Franka's Cobot Pump) as a tool: vacuum gripper protocol v1 on TCP 1339,
the pump's state machine, a suction cup on the flange (franka_sim/tools/__init__.py says what a
row ties together)."""

from franka_sim.physics.suction import CUP
from franka_sim.protocol.enums import VACUUM_GRIPPER_COMMAND_PORT
from franka_sim.robot.session import VACUUM_GRIPPER
from franka_sim.robot.vacuum_gripper import VacuumGripper
from franka_sim.tools import ToolKind

VACUUM = ToolKind(name="vacuum", label="vacuum gripper", port=VACUUM_GRIPPER_COMMAND_PORT,
                  service=VACUUM_GRIPPER, make_device=VacuumGripper, mount=CUP)
