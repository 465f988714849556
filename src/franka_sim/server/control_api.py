"""The control API over HTTP + JSON (aiohttp), served on the simulator's own event loop.

A thin adapter: it checks the request (a bearer token when one is set, a JSON object with
known fields) and calls the operation (server/control_ops.py), which checks the values. A
refusal is an HTTP error with `{"error": "..."}` and one log line saying what was wrong; nothing
changed, and the robot's stream goes on. docs/control_api.md documents every resource.

aiohttp because it is a well-kept asyncio HTTP server that runs on the loop the simulator
already has (uvloop under `franka-sim serve`): no thread of its own, and a request costs the
1 kHz stream nothing but the job it submits to the cycle thread.
"""

from __future__ import annotations

import hmac
import json
import logging
from typing import Any

from aiohttp import web

from franka_sim.control.errors import BadRequest, ControlError, Unauthorized
from franka_sim.server.control_ops import ControlOps
from franka_sim.server.faults.spec import KEYS as FAULT_KEYS

log = logging.getLogger(__name__)

MAX_BODY = 64 * 1024  # bytes: the largest request is a few hundred
FAULT_FIELDS = ("spec", *FAULT_KEYS, "seed")  # POST /faults


def _no_constants(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def parse_object(raw: bytes, allowed: dict[str, bool], *, optional_body: bool = False) -> dict:
    """The request's JSON object, with only `allowed` fields (name → required)."""
    if not raw.strip():
        if optional_body:
            return {}
        raise BadRequest("expected a JSON object in the request body")
    try:
        value = json.loads(raw.decode("utf-8"), parse_constant=_no_constants)
    except (UnicodeDecodeError, ValueError) as exc:  # JSONDecodeError is a ValueError
        raise BadRequest(f"malformed JSON: {exc}") from None
    if not isinstance(value, dict):
        raise BadRequest(f"expected a JSON object, not {type(value).__name__}")
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise BadRequest(f"unknown field(s) {', '.join(map(repr, unknown))} "
                         f"(expected {', '.join(allowed)})")
    missing = [name for name, required in allowed.items() if required and name not in value]
    if missing:
        raise BadRequest(f"missing field(s) {', '.join(map(repr, missing))}")
    return value


def _answer(result: Any) -> web.Response:
    return web.json_response(result)


class ControlApi:
    """The HTTP server of one simulator's control API."""

    def __init__(self, ops: ControlOps, token: str | None = None) -> None:
        self.ops = ops
        self._expected = None if token is None else f"Bearer {token}".encode()
        self._runner: web.AppRunner | None = None
        self._said_failed = False  # "stopped simulating" refusals are logged once
        app = web.Application(middlewares=[self._refusals], client_max_size=MAX_BODY)
        app.router.add_get("/health", self._health)
        app.router.add_get("/state", self._state)
        app.router.add_post("/reset", self._reset)
        app.router.add_get("/bodies", self._bodies)
        app.router.add_get("/bodies/{name:.+}", self._pose)
        app.router.add_put("/bodies/{name:.+}", self._set_pose)
        app.router.add_post("/push", self._push)
        app.router.add_post("/recording", self._start_recording)
        app.router.add_delete("/recording", self._finish_recording)
        app.router.add_get("/faults", self._faults)
        app.router.add_post("/faults", self._set_faults)
        app.router.add_delete("/faults", self._clear_faults)
        self.app = app

    async def start(self, host: str, port: int) -> None:
        runner = web.AppRunner(self.app, access_log=None, shutdown_timeout=1.0)
        await runner.setup()
        try:
            await web.TCPSite(runner, host, port).start()
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
                given = request.headers.get("Authorization", "").encode()
                if not hmac.compare_digest(given, self._expected):
                    raise Unauthorized("a bearer token is required (Authorization: Bearer "
                                       "<token>, the server's --control-token)"
                                       if not given else "wrong bearer token")
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
    async def _health(self, request: web.Request) -> web.Response:
        return _answer(self.ops.health())

    async def _state(self, request: web.Request) -> web.Response:
        return _answer(await self.ops.state())

    async def _reset(self, request: web.Request) -> web.Response:
        fields = parse_object(await request.read(), {"q": False, "gripper_width": False},
                              optional_body=True)
        return _answer(await self.ops.reset(**fields))

    async def _bodies(self, request: web.Request) -> web.Response:
        return _answer({"bodies": await self.ops.bodies()})

    async def _pose(self, request: web.Request) -> web.Response:
        return _answer(await self.ops.pose(request.match_info["name"]))

    async def _set_pose(self, request: web.Request) -> web.Response:
        fields = parse_object(await request.read(), {"position": True, "quaternion": False})
        return _answer(await self.ops.set_pose(request.match_info["name"], **fields))

    async def _push(self, request: web.Request) -> web.Response:
        fields = parse_object(await request.read(), {"body": True, "force": True,
                                                     "torque": False, "duration": False})
        return _answer(await self.ops.push(**fields))

    async def _start_recording(self, request: web.Request) -> web.Response:
        fields = parse_object(await request.read(), {"path": True})
        return _answer(await self.ops.start_recording(**fields))

    async def _finish_recording(self, request: web.Request) -> web.Response:
        return _answer(await self.ops.finish_recording())

    async def _faults(self, request: web.Request) -> web.Response:
        return _answer(await self.ops.faults())

    async def _set_faults(self, request: web.Request) -> web.Response:
        fields = parse_object(await request.read(), dict.fromkeys(FAULT_FIELDS, False))
        return _answer(await self.ops.set_faults(fields))

    async def _clear_faults(self, request: web.Request) -> web.Response:
        return _answer(await self.ops.clear_faults())
