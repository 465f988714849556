"""The older Desk's API (Panda, FR3 before system 5): a login that returns a session (sent
back as the `authorization` cookie), the control token requested under `/admin/api` and shown
in `/admin/api/system-status` and `/admin/api/control-token`, actions under `/desk/api` with
form bodies. What franky's `DeskWebSession`, franka-deskapi's login-based calls and the
franka_lock_unlock script (written for a Panda's system 4) send and parse (docs/desk.md)."""

from __future__ import annotations

import base64
import binascii

from franka_sim.desk.calls import Answer, Call, Routes
from franka_sim.desk.state import (EXECUTION, FORCE_CONFIRM_SECONDS, JOINTS, LOCKED,
                                   PROGRAMMING, UNLOCKED, Desk, DeskRefusal)
from franka_sim.desk.users import Users


def routes(desk: Desk, users: Users) -> Routes:
    api = Routes()
    add = api.add

    @add("POST", "/admin/api/login")
    def login(call: Call) -> Answer:
        body = call.json_object()
        session = users.login(body.get("login"), body.get("password"))
        if session is None:
            raise DeskRefusal(401, "Unauthorized", "wrong user name or password")
        return Answer(text=session)

    @add("POST", "/admin/api/logout")
    def logout(call: Call) -> Answer:
        users.logout(call.user)
        return Answer()

    @add("GET", "/admin/api/control-token")
    def active_token(call: Call) -> Answer:
        token = desk.token
        return Answer(body={"activeToken": None if token is None else {
            "id": token.id, "ownedBy": token.owner}})

    @add("POST", "/admin/api/control-token/fci")
    def fci_with_token(call: Call) -> Answer:
        body = call.json_object()
        desk.set_fci(call.control_token or body.get("token"), True)
        return Answer()

    @add("DELETE", "/admin/api/control-token/fci")
    def fci_off_with_token(call: Call) -> Answer:
        body = call.json_object(optional=True)
        desk.set_fci(call.control_token or body.get("token"), False)
        return Answer()

    @add("GET", "/admin/api/safety")
    def safety(call: Call) -> Answer:
        return Answer(body={"tokenForceTimeout": FORCE_CONFIRM_SECONDS})

    @add("GET", "/admin/api/system-status")
    def system_status(call: Call) -> Answer:
        token = desk.token
        return Answer(body={
            "controlToken": {"activeToken": None if token is None else {
                "id": token.id, "ownedBy": token.owner}},
            "derived": {"operatingMode": desk.operating_mode},
            "safety": {"brakeState": [desk.brakes] * JOINTS,
                       "recoverableErrors": {"td2Timeout": False},
                       "safetyControllerStatus": "Idle"},
            "fci": {"active": desk.fci_active},
            "endEffector": {"powered": desk.end_effector_powered},
        })

    @add("POST", "/admin/api/control-token/request")
    def request_token(call: Call) -> Answer:
        owner = call.json_object().get("requestedBy", call.user)
        request = desk.take(owner, force="force" in call.query)
        # Answered at once: the client polls system-status until its id is the active one.
        return Answer(body={"id": request.token.id, "token": request.token.secret})

    @add("DELETE", "/admin/api/control-token")
    def release(call: Call) -> Answer:
        body = call.json_object(optional=True)
        desk.release(call.control_token or body.get("token"))
        return Answer()

    @add("POST", "/desk/api/system/fci")
    def fci_on(call: Call) -> Answer:
        desk.set_fci(call.control_token or _form_token(call), True)
        return Answer()

    @add("DELETE", "/desk/api/system/fci")
    def fci_off(call: Call) -> Answer:
        desk.set_fci(call.control_token or _form_token(call), False)
        return Answer()

    @add("POST", "/admin/api/safety/td2-tests/execute")
    def self_tests(call: Call) -> Answer:
        desk.run_self_tests(call.control_token)
        return Answer(body={"code": "SuccessResponse"})

    api.actions([
        # System 4's brake actions: their multipart body ("force") changes nothing here.
        ("/desk/api/robot/open-brakes", lambda token: desk.set_brakes(token, UNLOCKED)),
        ("/desk/api/robot/close-brakes", lambda token: desk.lock_brakes()),
        ("/desk/api/gripper/homing", desk.home_gripper),
        # No recoverable safety error is simulated: nothing left to acknowledge.
        ("/admin/api/safety/recoverable-safety-errors/acknowledge", desk.check_token),
    ])
    api.actions([
        ("/desk/api/joints/unlock", lambda token: desk.set_brakes(token, UNLOCKED)),
        ("/desk/api/joints/lock", lambda token: desk.set_brakes(token, LOCKED)),
        ("/desk/api/operating-mode/programming",
         lambda token: desk.set_operating_mode(token, PROGRAMMING)),
        ("/desk/api/operating-mode/execution",
         lambda token: desk.set_operating_mode(token, EXECUTION)),
    ], form=True)
    return api


def _form_token(call: Call) -> str | None:
    """The token the older Desk's FCI form carries (base64 of it)."""
    encoded = call.form().get("token")
    if not encoded:
        return None
    try:
        return base64.b64decode(encoded, validate=True).decode("ascii")
    except (binascii.Error, UnicodeDecodeError):
        raise DeskRefusal(400, "BadRequest", "the form's token is not base64") from None
