"""The Desk over HTTPS (aiohttp, TLS), on the simulator's own event loop: a thin adapter.

Each request becomes a `Call` for the Desk's service (desk/service.py), which answers it; a
take that queues behind the holder waits here, on the loop, until the Desk grants it or its
timeout passes; an answered change is then applied to the robot (server/desk_effects.py). The
Pilot's button events go out on a WebSocket. A handshake that is not TLS, or a request that is
not HTTP, costs that one connection; the Desk serves on.
"""

from __future__ import annotations

import asyncio
import logging

from aiohttp import WSMsgType, web

from franka_sim.desk.calls import MAX_BODY, Answer, Call
from franka_sim.desk.service import PILOT_EVENTS, DeskService
from franka_sim.control.errors import ControlError
from franka_sim.desk.state import DeskRefusal
from franka_sim.server.http_log import quiet_aiohttp
from franka_sim.desk.users import DEFAULT_USER, Users, parse_user

log = logging.getLogger(__name__)


def users_of(config) -> Users:
    accounts = dict(parse_user(text) for text in config.desk_users) or dict([DEFAULT_USER])
    return Users(accounts)


class DeskServer:
    def __init__(self, robot, effects) -> None:
        self.robot, self.effects = robot, effects
        self.desk = robot.control.desk_state
        # (log lines say "Desk"; in a world of several arms the line's robot name says whose)
        self.service = DeskService(self.desk, users_of(robot.config), "Desk")
        self._changed = asyncio.Event()
        self.desk.watchers.append(self._changed.set)
        self._sockets: set[web.WebSocketResponse] = set()
        self._runner: web.AppRunner | None = None
        quiet_aiohttp()
        app = web.Application(client_max_size=MAX_BODY)
        app.router.add_route("*", r"/{tail:[\s\S]*}", self._handle)  # (a newline too)
        self.app = app

    async def serve_socket(self, sock, context) -> None:
        runner = web.AppRunner(self.app, access_log=None, shutdown_timeout=1.0,
                               handle_signals=False)
        await runner.setup()
        try:
            await web.SockSite(runner, sock, ssl_context=context).start()
        except BaseException:
            await runner.cleanup()
            raise
        self._runner = runner

    async def stop(self) -> None:
        self.desk.watchers.remove(self._changed.set)
        for ws in list(self._sockets):
            await ws.close()
        runner, self._runner = self._runner, None
        if runner is not None:
            await runner.cleanup()

    async def _handle(self, request: web.Request) -> web.StreamResponse:
        call = Call(request.method, request.path, dict(request.query),
                    {name.lower(): value for name, value in request.headers.items()})
        try:
            call.body = await request.read()
        except web.HTTPRequestEntityTooLarge:
            answer = self.service.refused(call, DeskRefusal(
                413, "PayloadTooLarge", f"the body is over {MAX_BODY} bytes"))
            return _response(answer)
        if call.path == PILOT_EVENTS and request.method == "GET":
            return await self._pilot_events(request, call)
        answer = self.service.handle(call)
        if answer.request is not None:
            answer = await self._wait(call, answer)
        if answer.status == 200 and call.method != "GET":
            refused = self.effects.homing_refused()
            if refused is not None:
                return _response(self.service.refused(call, DeskRefusal(409, "Conflict", refused)))
            log.info("Desk: %s %s by %s", call.method, call.path,
                     call.user or "someone logging in")
            try:
                await self.effects.apply()
            except OSError as exc:  # the FCI's or the tool's port taken meanwhile
                log.error("Desk: %s %s could not be applied: %s", call.method, call.path,
                          exc.strerror or exc)
                answer = Answer(status=500, body={
                    "code": "InternalError", "error": f"could not be applied: {exc}"})
            except ControlError as refusal:  # the robot refused it (the Hand busy by now)
                answer = self.service.refused(call, DeskRefusal(409, "Conflict", refusal.message))
        return _response(answer)

    async def _wait(self, call: Call, answer: Answer) -> Answer:
        """A take that waits for the token: until granted, or its timeout passes."""
        request, loop = answer.request, asyncio.get_running_loop()
        deadline = loop.time() + answer.timeout
        while not request.granted and not request.withdrawn:
            left = deadline - loop.time()
            if left <= 0:
                break
            self._changed.clear()
            try:
                await asyncio.wait_for(self._changed.wait(), left)
            except asyncio.TimeoutError:
                break
        if not request.granted:
            self.desk.withdraw(request)
        return self.service.finish(call, answer)

    async def _pilot_events(self, request: web.Request, call: Call) -> web.StreamResponse:
        if self.service.caller(call) is None:
            return _response(self.service.refused(call, DeskRefusal(
                401, "Unauthorized", "wrong or missing credentials")))
        ws = web.WebSocketResponse()
        if not ws.can_prepare(request).ok:
            return _response(self.service.refused(call, DeskRefusal(
                400, "BadRequest", "the Pilot's events are a WebSocket (an Upgrade request)")))
        await ws.prepare(request)
        events: asyncio.Queue = asyncio.Queue()
        self.desk.listeners.append(events.put_nowait)
        self._sockets.add(ws)

        async def send() -> None:
            while True:
                await ws.send_json(await events.get())
        sender = asyncio.create_task(send())
        try:
            async for message in ws:
                if message.type is WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            self.desk.listeners.remove(events.put_nowait)
            self._sockets.discard(ws)
        return ws


def _response(answer: Answer) -> web.Response:
    headers = {"WWW-Authenticate": 'Basic realm="Desk"'} if answer.status == 401 else None
    if answer.text is not None:
        return web.Response(status=answer.status, text=answer.text, headers=headers)
    if answer.body is None:
        return web.Response(status=answer.status, headers=headers)
    return web.json_response(answer.body, status=answer.status, headers=headers)
