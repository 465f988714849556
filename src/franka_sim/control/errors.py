"""What the control API answers instead of a result: one exception type per kind of refusal.

The client raises them with the server's message; an embedded `FrankaSim` raises the very same
ones, so code that drives a simulator catches one set of names either way. Standard library
only: the server and the client both import it.
"""

from __future__ import annotations


class ControlError(Exception):
    """The control API refused or could not do something: `status` (the HTTP status, None when
    no answer came) and `message` (the server's own words)."""

    status: int | None = None

    def __init__(self, message: str, status: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        if status is not None:
            self.status = status

    def __str__(self) -> str:
        return self.message if self.status is None else f"{self.status}: {self.message}"


class BadRequest(ControlError):
    """Malformed or invalid input (400; 422 from a server that says so): nothing changed."""

    status = 400


class Unauthorized(ControlError):
    """The server wants a bearer token (--control-token) and got none, or another one (401)."""

    status = 401


class NotFound(ControlError):
    """No such body, or no such resource (404)."""

    status = 404


class Conflict(ControlError):
    """Not now: a motion, an error recovery or a gripper action is under way, or the body
    cannot be placed (409). Nothing changed."""

    status = 409


class Failed(ControlError):
    """The simulator stopped simulating: its cycle failed (503, the message says why). Under
    `franka-sim serve` the process exits non-zero within a second, so a supervisor restarts it."""

    status = 503


class Unreachable(ControlError):
    """No answer: nothing listens there (connection refused), or the answer took too long."""


def error_for(status: int, message: str) -> ControlError:
    """The exception a client raises for an HTTP error status."""
    kinds = {400: BadRequest, 422: BadRequest, 401: Unauthorized, 404: NotFound, 409: Conflict,
             503: Failed}
    return kinds.get(status, ControlError)(message, status)


def header_safe(token: str) -> bool:
    """A bearer token an HTTP header carries as given: printable, no space around it (the
    server strips the header's value)."""
    return bool(token) and token.isprintable() and token == token.strip()
