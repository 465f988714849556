"""One robot's Desk as a service: who calls, which route, and what is answered.

`handle(call)` checks the caller (401 unless the call is the older Desk's login), finds the
route in either dialect (404 with the routes served; 405 for a known path under another
method), runs it, and turns a refusal into its JSON answer. Every refusal is logged in one
line naming what was wrong; the Desk is unchanged by it.
"""

from __future__ import annotations

import logging

from franka_sim.desk import legacy_api, rest_api
from franka_sim.desk.calls import Answer, Call
from franka_sim.desk.state import Desk, DeskRefusal
from franka_sim.desk.users import Users

log = logging.getLogger(__name__)

UNAUTHENTICATED = {("POST", "/admin/api/login")}
PILOT_EVENTS = "/desk/api/navigation/events"  # the Pilot's button events (a WebSocket)


class DeskService:
    def __init__(self, desk: Desk, users: Users, label: str = "Desk") -> None:
        self.desk, self.users, self.label = desk, users, label
        self.dialects = (rest_api.routes(desk), legacy_api.routes(desk, users))

    def caller(self, call: Call) -> str | None:
        cookie = _cookie(call.header("cookie"), "authorization")
        return self.users.caller(call.header("authorization"), cookie)

    def handle(self, call: Call) -> Answer:
        try:
            return self._handle(call)
        except DeskRefusal as refusal:
            return self.refused(call, refusal)

    def refused(self, call: Call, refusal: DeskRefusal) -> Answer:
        log.warning("%s: %s %s refused (%d %s): %s", self.label, call.method, call.path,
                    refusal.status, refusal.code, refusal.message)
        return Answer(status=refusal.status, body=refusal.body())

    def finish(self, call: Call, answer: Answer) -> Answer:
        """A pending take's answer, once it was granted or gave up."""
        try:
            return answer.then(answer.request)
        except DeskRefusal as refusal:
            return self.refused(call, refusal)

    def _handle(self, call: Call) -> Answer:
        if (call.method, call.path) not in UNAUTHENTICATED:
            call.user = self.caller(call)
            if call.user is None:
                raise DeskRefusal(401, "Unauthorized", "wrong or missing credentials (HTTP "
                                  "Basic, or the older Desk's login session)")
        for routes in self.dialects:
            handler = routes.find(call.method, call.path)
            if handler is not None:
                return handler(call)
        if any(routes.knows(call.path) for routes in self.dialects) or call.path == PILOT_EVENTS:
            raise DeskRefusal(405, "MethodNotAllowed",
                              f"{call.method} is not allowed on {call.path}")
        raise DeskRefusal(404, "NotFound", f"the Desk serves no {call.path} (docs/desk.md "
                          "lists what it serves)")


def _cookie(header: str | None, name: str) -> str | None:
    if not header:
        return None
    for part in header.split(";"):
        key, sep, value = part.strip().partition("=")
        if sep and key == name:
            return value
    return None
