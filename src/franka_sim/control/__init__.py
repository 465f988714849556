"""The simulator's control API from Python: `Control(host)` and the errors it raises.

Standard library only (no HTTP package to install next to a test suite). The HTTP resources
themselves are documented in docs/control_api.md.
"""

from franka_sim.control.errors import (
    BadRequest,
    Conflict,
    ControlError,
    Failed,
    NotFound,
    Unauthorized,
    Unreachable,
)



def __getattr__(name: str):
    """The client (http.client, email) only when asked for: a serving process imports the
    table and the errors from here, never the client."""
    if name in ("Control", "DEFAULT_PORT"):
        from franka_sim.control import client

        return getattr(client, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["DEFAULT_PORT", "BadRequest", "Conflict", "Control", "ControlError", "Failed",
           "NotFound", "Unauthorized", "Unreachable"]
