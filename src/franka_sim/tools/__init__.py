"""End-effector tools: what one tool is made of, and the tools an arm can carry.

A tool is four pieces, each in its own layer, tied together by one `ToolKind` row here:
- its wire protocol (protocol/; the Franka Hand's: gripper_messages.py) and its session's
  tables (robot/session.py `Service`), served on its own TCP port beside the FCI;
- its device, a sans-IO state machine clocked by the cycle number (robot/tool.py; the Hand:
  robot/hand.py);
- its physical part on the flange, built into the arm's model and attached to the world
  (physics/tool.py; the Hand's fingers: physics/fingers.py);
- this row: its name (`--tool NAME`), its port, and the factories of the pieces above.
The arm's cycle, the arm's physics, the robot's server and replay use a tool only through those
contracts: adding one is a row and its pieces, nothing else.

Without a tool (`--tool none`) the flange carries the Hand's body, rigid, and no tool service
answers (its port refuses connections), as on a robot whose Hand is not in use.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:
    from franka_sim.physics.tool import ToolMount
    from franka_sim.robot.session import Service
    from franka_sim.robot.tool import ToolDevice

NO_TOOL = "none"
# Every tool: its name, and the module holding its row (a `ToolKind` named in capitals). Only
# names here, so that checking a --tool costs no import of the layers a row brings.
TOOL_MODULES = {"hand": "franka_sim.tools.hand", "vacuum": "franka_sim.tools.vacuum"}


@dataclass(frozen=True)
class ToolKind:
    name: str  # what --tool says
    label: str  # how logs and docs name it ("Franka Hand")
    port: int  # its service's TCP port (its state datagrams go to the port its client announces)
    service: Service  # its session's wire tables
    make_device: Callable[[], ToolDevice]
    mount: ToolMount  # its physical part


def tool_kinds() -> dict[str, ToolKind]:
    """Every tool by name (imported here, not at import: the rows bring their layers)."""
    return {name: _row(name) for name in TOOL_MODULES}


def _row(name: str) -> ToolKind:
    module = importlib.import_module(TOOL_MODULES[name])
    rows = [row for row in vars(module).values() if isinstance(row, ToolKind)]
    assert len(rows) == 1 and rows[0].name == name, f"{module.__name__}: one row named {name!r}"
    return rows[0]


def tool_names() -> tuple[str, ...]:
    return (*TOOL_MODULES, NO_TOOL)


def tool_kind(name: str) -> ToolKind | None:
    """The tool of that name (None: `none`); KeyError naming the choices."""
    if name == NO_TOOL:
        return None
    if name not in TOOL_MODULES:
        raise KeyError(f"no tool {name!r} (one of {', '.join(tool_names())})")
    return _row(name)
