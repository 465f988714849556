"""The FR3 system 5+ Desk API (`/api/...`): HTTP Basic on every call, JSON bodies, the
control token in `X-Control-Token`, actions as `resource:verb`. What franky's `Desk`,
franka-desk and franka-deskapi send and parse (docs/desk.md lists every route)."""

from __future__ import annotations

import math

from franka_sim.desk.calls import Answer, Call, Routes
from franka_sim.desk.state import (JOINTS, LOCKED, OPERATING_MODES, UNLOCKED, Desk,
                                   DeskRefusal, Request)

MAX_TAKE_WAIT = 300.0  # s a take may queue behind the holder (the adapter's bound)


def routes(desk: Desk) -> Routes:
    api = Routes()
    add = api.add

    @add("GET", "/api/system")
    def system(call: Call) -> Answer:
        return Answer(body={"status": "Started", "operatingMode": {"status": desk.operating_mode},
                            "controlSerialNumber": desk.serial, "armType": _arm_type(desk)})

    @add("GET", "/api/system/operating-mode")
    def operating_mode(call: Call) -> Answer:
        return Answer(body={"status": desk.operating_mode})

    @add("POST", "/api/system/operating-mode:change")
    def change_mode(call: Call) -> Answer:
        desired = call.json_object().get("desiredOperatingMode")
        if desired not in OPERATING_MODES:
            raise DeskRefusal(400, "BadRequest", f"desiredOperatingMode {desired!r}: expected "
                              f"{' or '.join(OPERATING_MODES)}")
        desk.set_operating_mode(call.control_token, desired)
        return Answer()

    @add("GET", "/api/system/control-token")
    def token_info(call: Call) -> Answer:
        token, pending = desk.token, desk.pending
        return Answer(body={
            "owner": None if token is None else token.owner,
            "tokenId": None if token is None else token.id,
            "requester": None if pending is None else pending.token.owner})

    @add("POST", "/api/system/control-token:take")
    def take(call: Call) -> Answer:
        body = call.json_object()
        owner, timeout = body.get("owner", call.user), body.get("timeout")
        if timeout is None:
            raise DeskRefusal(400, "BadRequest", "no timeout: the seconds to wait for the "
                              f"token while another holds it, in (0, {MAX_TAKE_WAIT:g}]")
        if (isinstance(timeout, bool) or not isinstance(timeout, (int, float))
                or not math.isfinite(timeout) or timeout <= 0 or timeout > MAX_TAKE_WAIT):
            raise DeskRefusal(400, "BadRequest", f"timeout {timeout!r}: expected seconds in "
                              f"(0, {MAX_TAKE_WAIT:g}]")
        request = desk.take(owner)
        return Answer(request=request, timeout=float(timeout), then=_granted)

    @add("GET", "/api/fci")
    def fci(call: Call) -> Answer:
        return Answer(body={"status": "Active" if desk.fci_active else "Inactive"})

    @add("GET", "/api/arm")
    def arm(call: Call) -> Answer:
        return Answer(body={"status": "Connected", "type": _arm_type(desk)})

    @add("GET", "/api/arm/joints")
    def joints(call: Call) -> Answer:
        return Answer(body=[{"brakeStatus": desk.brakes} for _ in range(JOINTS)])

    @add("GET", "/api/arm/warnings")
    def warnings(call: Call) -> Answer:
        return Answer(body=[])

    @add("GET", "/api/end-effector/power")
    def ee_power(call: Call) -> Answer:
        return Answer(body={"status": "On" if desk.end_effector_powered else "Off"})

    @add("GET", "/api/safety/self-tests")
    def self_tests(call: Call) -> Answer:
        return Answer(body={"status": desk.self_tests})

    @add("GET", "/api/safety/recovery")
    def recovery(call: Call) -> Answer:
        # The Desk's safety errors are not simulated (docs/desk.md): nothing to recover.
        return Answer(body={"recovery": None})

    @add("POST", "/api/safety/recovery:confirm")
    def confirm_recovery(call: Call) -> Answer:
        call.json_object(optional=True)
        raise DeskRefusal(424, "PreconditionFailed", "there is no safety error to recover",
                          ("NoRecoveryPending",))

    api.actions([
        ("/api/system/control-token:release", desk.release),
        ("/api/fci:activate", lambda token: desk.set_fci(token, True)),
        ("/api/fci:deactivate", lambda token: desk.set_fci(token, False)),
        ("/api/arm/joints:unlock", lambda token: desk.set_brakes(token, UNLOCKED)),
        ("/api/arm/joints:lock", lambda token: desk.set_brakes(token, LOCKED)),
        ("/api/end-effector/power:on", lambda token: desk.set_end_effector_power(token, True)),
        ("/api/end-effector/power:off", lambda token: desk.set_end_effector_power(token, False)),
        ("/api/safety/self-tests:execute", desk.run_self_tests),
    ])
    return api


def _granted(request: Request) -> Answer:
    """A take's answer once it was granted, or its timeout passed."""
    if not request.granted and request.replaced:  # (one request waits at a time)
        raise DeskRefusal(424, "Timeout", "the control token is held by another user, and a "
                          "later request for it replaced this one before it was released")
    if not request.granted:
        raise DeskRefusal(424, "Timeout", "the control token is held by "
                          "another user, who did not release it within the timeout")
    return Answer(body={"token": request.token.secret, "tokenId": request.token.id})


def _arm_type(desk: Desk) -> str:
    """The arm's type as the Desk names it: a Panda's description ("fer") is a FER, every
    other one an FR3 (as robot/checks/figures.py picks their limits)."""
    return "FER" if desk.robot == "fer" else "FR3"
