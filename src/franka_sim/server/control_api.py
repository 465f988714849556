"""The control API over HTTP + JSON (aiohttp), served on the simulator's own event loop.

A thin adapter made from the table of operations (control/table.py): one route per row, at
its method and path. It checks the request (a bearer token when one is set, a JSON object with
the row's fields) and calls the robot's implementation of that row (operations/arm.py,
operations/base.py), which checks the values; a row the robot's kind does not have answers 404
saying so. A refusal is an HTTP error with `{"error": "..."}` and one log line saying what was
wrong; nothing changed, and the robot's stream goes on. docs/control_api.md documents every
resource.

aiohttp because it is a well-kept asyncio HTTP server that runs on the loop the simulator
already has (uvloop under `franka-sim serve`): no thread of its own, and a request costs the
1 kHz stream nothing but the job it submits to the cycle thread. It is imported on the first
connection to the port (server/control_port.py), not before.
"""

from __future__ import annotations

import hmac
import inspect
import logging
import re

from aiohttp import web
from aiohttp.web_protocol import RequestPayloadError

from franka_sim.control.errors import BadRequest, ControlError, NotFound, Unauthorized
from franka_sim.control.table import OPERATIONS, Operation, served_by
from franka_sim.json_body import json_object
from franka_sim.server.http_log import quiet_aiohttp

log = logging.getLogger(__name__)

MAX_BODY = 64 * 1024  # bytes: the largest request is a few hundred




def parse_object(raw: bytes, allowed: dict[str, bool], *, optional_body: bool = False) -> dict:
    """The request's JSON object, with only `allowed` fields (name → required)."""
    try:
        value = json_object(raw, optional=optional_body)
    except ValueError as exc:
        raise BadRequest(str(exc)) from None
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise BadRequest(f"unknown field(s) {', '.join(map(repr, unknown))} "
                         f"(expected {', '.join(allowed)})")
    missing = [name for name, required in allowed.items() if required and name not in value]
    if missing:
        raise BadRequest(f"missing field(s) {', '.join(map(repr, missing))}")
    return value


def route_path(operation: Operation) -> str:
    """aiohttp's pattern of the row's path: a path argument takes the rest of the path, `/`
    included (a body's name: `/bodies/scene/cube`)."""
    return re.sub(r"\{(\w+)\}", r"{\1:.+}", operation.path)


class ControlApi:
    """The HTTP server of one robot's control API: `ops` is its implementation (its `kind`
    says which rows it has)."""

    def __init__(self, ops, token: str | None = None) -> None:
        self.ops = ops
        self._expected = None if token is None else token.encode()
        self._runner: web.AppRunner | None = None
        self._said_failed = False  # "stopped simulating" refusals are logged once
        quiet_aiohttp()
        app = web.Application(middlewares=[self._refusals], client_max_size=MAX_BODY)
        served = served_by(ops.kind)
        for operation in OPERATIONS:
            handler = (self._serve(operation) if operation in served
                       else self._absent(operation, served))
            if operation.method == "GET":  # (add_get: HEAD too)
                app.router.add_get(route_path(operation), handler)
            else:
                app.router.add_route(operation.method, route_path(operation), handler)
        self.app = app

    async def serve_socket(self, sock) -> None:
        """Serve on `sock`, a listening socket (server/control_port.py binds it at start)."""
        runner = web.AppRunner(self.app, access_log=None, shutdown_timeout=1.0)
        await runner.setup()
        try:
            await web.SockSite(runner, sock).start()
        except BaseException:
            await runner.cleanup()
            raise
        self._runner = runner

    async def stop(self) -> None:
        runner, self._runner = self._runner, None
        if runner is not None:
            await runner.cleanup()

    # -- every request -----------------------------------------------------------------------------
    @web.middleware
    async def _refusals(self, request: web.Request, handler) -> web.StreamResponse:
        """The token, then the handler; whatever is refused becomes `{"error": ...}`."""
        try:
            if self._expected is not None:
                given = request.headers.get("Authorization", "")
                scheme, _, credentials = given.strip().partition(" ")
                if scheme.lower() != "bearer":  # (a scheme's name is case-insensitive)
                    raise Unauthorized("a bearer token is required (Authorization: Bearer "
                                       "<token>, the server's --control-token)"
                                       if not given else "not a bearer token (Authorization: "
                                       "Bearer <token>)")
                # (the header's bytes as sent: aiohttp keeps those that are not UTF-8 escaped)
                sent = credentials.strip().encode("utf-8", "surrogateescape")
                if not hmac.compare_digest(sent, self._expected):
                    raise Unauthorized("wrong bearer token")
            return await handler(request)
        except ControlError as refusal:
            status, message = refusal.status or 500, refusal.message
        except web.HTTPException as exc:  # no such route or method, body too large
            if exc.status < 400:
                raise
            status, message = exc.status, exc.reason
            if exc.status == 405:
                message = f"{request.method} is not allowed on {request.path}"
            elif exc.status == 404:
                message = f"no resource {request.path} (see docs/control_api.md)"
        except RequestPayloadError as exc:  # a body its Content-Encoding does not decode
            # (aiohttp's text: "400, message:\n  Can not decode content-encoding: gzip")
            said = " ".join(line.strip() for line in str(exc).splitlines())
            status = 400
            message = f"the request's body cannot be read: {said.split('message:')[-1].strip()}"
        except ConnectionError:  # (the client hung up before its body was whole)
            log.warning("control API: %s %s: the client left before its request was whole",
                        request.method, request.path)
            return web.Response(status=400)  # (nobody reads it)
        except Exception as exc:  # noqa: BLE001 - answered, not raised into aiohttp
            log.exception("control API: %s %s failed", request.method, request.path)
            return web.json_response({"error": f"internal error: {exc}"}, status=500)
        if status != 503 or not self._said_failed:  # (a dead world was logged loudly already)
            log.warning("control API: %s %s refused (%d): %s", request.method, request.path,
                        status, message)
            self._said_failed = self._said_failed or status == 503
        headers = {"WWW-Authenticate": "Bearer"} if status == 401 else None
        return web.json_response({"error": message}, status=status, headers=headers)

    # -- resources ---------------------------------------------------------------------------------
    def _serve(self, operation: Operation):
        """The handler of a row: its path's arguments and its body's fields, handed to the
        implementation's method of the row's name."""
        implementation = getattr(self.ops, operation.name)
        takes_body = bool(operation.body)

        async def handle(request: web.Request) -> web.Response:
            arguments = {name: request.match_info[name] for name in operation.path_args}
            if takes_body:
                fields = parse_object(await request.read(), operation.fields,
                                      optional_body=operation.body_optional)
                if operation.collect is not None:
                    arguments[operation.collect] = fields
                else:
                    arguments.update(fields)
            result = implementation(**arguments)
            if inspect.isawaitable(result):
                result = await result
            if operation.answer_key is not None:
                result = {operation.answer_key: result}
            return web.json_response(result)
        return handle

    def _absent(self, operation: Operation, served: tuple[Operation, ...]):
        """The handler of a row this robot's kind does not have: 404, saying what it has."""
        paths = list(dict.fromkeys(row.path for row in served))
        message = (f"the {self.ops.kind.value} has no {operation.method} {operation.path} "
                   f"(its control API serves {', '.join(paths)})")

        async def handle(request: web.Request) -> web.Response:
            raise NotFound(message)
        return handle
