"""A Desk call and its answer as plain values, and the route table both dialects fill.

The HTTPS adapter turns a request into a `Call` and an `Answer` into a response; everything
between (who calls, which route, the body's shape, the Desk's verdict) is plain Python, so a
test drives it without sockets.
"""

from __future__ import annotations

import urllib.parse
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable

from franka_sim.desk.state import DeskRefusal, Request
from franka_sim.json_body import json_object

MAX_BODY = 64 * 1024  # bytes; the largest Desk body is a few dozen


@dataclass
class Call:
    method: str
    path: str
    query: dict[str, str] = field(default_factory=dict)
    headers: dict[str, str] = field(default_factory=dict)  # lower-case names
    body: bytes = b""
    user: str | None = None  # who called, once the service checked it

    def header(self, name: str) -> str | None:
        return self.headers.get(name.lower())

    @property
    def control_token(self) -> str | None:
        return self.header("x-control-token")

    def json_object(self, *, optional: bool = False) -> dict:
        """The body as a JSON object (400 when it is not one)."""
        try:
            return json_object(self.body, optional=optional)
        except ValueError as exc:
            raise DeskRefusal(400, "BadRequest", str(exc)) from None

    def form(self) -> dict[str, str]:
        """The body as x-www-form-urlencoded fields (400 when it is not)."""
        try:
            text = self.body.decode("ascii")
            return dict(urllib.parse.parse_qsl(text, keep_blank_values=True,
                                               strict_parsing=bool(text)))
        except (UnicodeDecodeError, ValueError):
            raise DeskRefusal(400, "BadRequest", "malformed form body") from None


@dataclass
class Answer:
    """200 with a JSON body (or `text`), or a pending take: the adapter waits on the Desk until
    `request` is granted or `timeout` s passed, then calls `then(request)` for the answer."""

    status: int = 200
    body: Any = None
    text: str | None = None
    request: Request | None = None
    timeout: float = 0.0
    then: Callable[[Request], "Answer"] | None = None


Handler = Callable[[Call], Answer]
# A call that only acts, with the caller's control token, and answers an empty 200: a POST of
# (path, effect(token)).
Action = tuple[str, Callable[[str | None], object]]


class Routes:
    """(method, path) → handler; a path known under another method answers 405."""

    def __init__(self) -> None:
        self.table: dict[tuple[str, str], Handler] = {}

    def add(self, method: str, path: str) -> Callable[[Handler], Handler]:
        def register(handler: Handler) -> Handler:
            self.table[(method, path)] = handler
            return handler
        return register

    def actions(self, rows: Iterable[Action], *, form: bool = False) -> None:
        """POSTs that only act; with `form` each carries a form the action does not read (a
        malformed one is still refused), else a body that is not read."""
        for path, effect in rows:
            self.table[("POST", path)] = _acting(effect, form)

    def find(self, method: str, path: str) -> Handler | None:
        return self.table.get((method, path))

    def knows(self, path: str) -> bool:
        return any(known == path for _, known in self.table)

    def paths(self) -> list[str]:
        return sorted({f"{method} {path}" for method, path in self.table})


def _acting(effect: Callable[[str | None], object], form: bool) -> Handler:
    def handler(call: Call) -> Answer:
        if form:
            call.form()
        effect(call.control_token)
        return Answer()
    return handler
