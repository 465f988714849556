"""The Franka Hand as a tool: gripper protocol v3 on TCP 1338, the Hand's state machine, its
two driven fingers (franka_sim/tools/__init__.py says what a row ties together)."""

from franka_sim.physics.fingers import FINGERS
from franka_sim.robot.hand import Hand
from franka_sim.robot.session import GRIPPER
from franka_sim.tools import ToolKind

HAND = ToolKind(name="hand", label="Franka Hand", port=1338, service=GRIPPER, make_device=Hand,
                mount=FINGERS)
