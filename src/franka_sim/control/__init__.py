"""The simulator's control API from Python: `Control(host)` and the errors it raises.

Standard library only (no HTTP package to install next to a test suite). The HTTP resources
themselves are documented in docs/control_api.md.
"""

from franka_sim.control.client import DEFAULT_PORT, Control
from franka_sim.control.errors import (
    BadRequest,
    Conflict,
    ControlError,
    Failed,
    NotFound,
    Unauthorized,
    Unreachable,
)

__all__ = ["DEFAULT_PORT", "BadRequest", "Conflict", "Control", "ControlError", "Failed",
           "NotFound", "Unauthorized", "Unreachable"]
