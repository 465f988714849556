"""The Desk's state machine: what a Desk call may change, and whether it may.

No sockets and no clock: a call is a method, a refusal is a `DeskRefusal` (the HTTP status, a
code from Franka's vocabulary, a reason), and anything that waits (a control-token take that
queues behind the holder, a forced take awaiting the Pilot's button) is a pending `Request`
the adapter waits on; every change tells the `watchers`, so a waiter knows when to look again.
What the Desk leaves the robot in is read off `fci_active`, `arm_ready` and
`end_effector_powered`; the server applies it (server/desk_port.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from franka_sim.config import DESK_BOOTS

LOCKED, UNLOCKED = "Locked", "Unlocked"
PROGRAMMING, EXECUTION = "Programming", "Execution"
OPERATING_MODES = (PROGRAMMING, EXECUTION)
BRAKE_STATES = (LOCKED, UNLOCKED)
PILOT_BUTTONS = ("circle", "cross", "check", "up", "down", "left", "right")
# The button that confirms physical access for a forced control-token take (the Pilot's top,
# circle button, as franky's prompt asks for).
CONFIRM_BUTTON = "circle"
# Seconds a forced take's requester is told it has to press it (/admin/api/safety's
# tokenForceTimeout; the real Desk's figure is unpublished: ours). The take itself waits on.
FORCE_CONFIRM_SECONDS = 15
JOINTS = 7
BOOTS = DESK_BOOTS


def _secret() -> str:
    import secrets

    return secrets.token_urlsafe(24)


class DeskRefusal(Exception):
    """A call the Desk refuses: HTTP `status`, Franka's `code`, why, and `details` (the
    unmet preconditions a 424 lists)."""

    def __init__(self, status: int, code: str, message: str, details: tuple[str, ...] = ()):
        super().__init__(message)
        self.status, self.code, self.message, self.details = status, code, message, details

    def body(self) -> dict:
        body = {"code": self.code, "message": self.message, "error": self.message}
        if self.details:
            body["details"] = list(self.details)
        return body


@dataclass
class Token:
    """The control token: who holds it, its id and its secret (sent as X-Control-Token)."""

    id: int
    secret: str
    owner: str


@dataclass
class Request:
    """A take that could not be granted at once: it waits for the holder's release, or, forced,
    for a press of the Pilot's confirm button. `token` once granted; `withdrawn` once given up."""

    token: Token
    force: bool
    withdrawn: bool = False
    granted: bool = False
    replaced: bool = False  # withdrawn for a later request (one waits at a time)


@dataclass
class Desk:
    """One robot's Desk, as it boots (`ready`: FCI active, brakes open, Execution, as the
    simulator always served; `locked`: as after power-on)."""

    boot: str = "ready"
    # The arm's kind: a Panda ("fer") has no Programming mode to boot in (its system 4 Desk
    # only opens the brakes and activates the FCI; the enabling device decides the rest).
    robot: str = "fr3"
    serial: str = "franka-sim"
    new_secret: Callable[[], str] = field(default=lambda: _secret())
    brakes: str = field(init=False)
    operating_mode: str = field(init=False)
    fci: bool = field(init=False)
    end_effector_powered: bool = True
    token: Token | None = None
    pending: Request | None = None
    self_tests: str = "Finished"
    gripper_homings: int = 0  # the Hand homings the Desk asked for (server/desk_effects.py)
    _next_id: int = 1
    # Who hears the Pilot's button events ({"circle": True}): the adapter's subscribers.
    listeners: list[Callable[[dict], None]] = field(default_factory=list)
    # Who is told of every change (a take waiting for the token looks again).
    watchers: list[Callable[[], None]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.boot not in BOOTS:
            raise ValueError(f"desk boot {self.boot!r}: expected one of {', '.join(BOOTS)}")
        self._power_on()

    def _power_on(self) -> None:
        ready = self.boot == "ready"
        self.brakes = UNLOCKED if ready else LOCKED
        self.operating_mode = EXECUTION if ready or self.robot == "fer" else PROGRAMMING
        self.fci = ready
        self.end_effector_powered = True
        self.token = None
        if self.pending is not None:
            self.pending.withdrawn = True
        self.pending = None
        self.self_tests = "Finished"

    def power_on(self) -> None:
        """As the robot starts again (the control API's reset): its boot state, no token."""
        self._power_on()
        self._changed()

    # -- what the robot is left in ------------------------------------------------------------
    @property
    def fci_active(self) -> bool:
        return self.fci

    @property
    def arm_ready(self) -> bool:
        """The arm takes FCI motions: brakes open and in Execution."""
        return self.brakes == UNLOCKED and self.operating_mode == EXECUTION

    def snapshot(self) -> dict:
        """The whole state, as the control API shows it."""
        token, pending = self.token, self.pending
        return {
            "brakes": self.brakes, "operating_mode": self.operating_mode,
            "fci": "Active" if self.fci else "Inactive",
            "end_effector_power": "On" if self.end_effector_powered else "Off",
            "control_token": None if token is None else {"owner": token.owner, "id": token.id},
            "pending_request": None if pending is None else {
                "owner": pending.token.owner, "id": pending.token.id, "force": pending.force},
            "self_tests": self.self_tests, "arm_ready": self.arm_ready,
        }

    def _changed(self) -> None:
        for watcher in list(self.watchers):
            watcher()

    # -- the control token -----------------------------------------------------------------------
    def _issue(self, owner: str) -> Token:
        token = Token(self._next_id, self.new_secret(), owner)
        self._next_id += 1
        return token

    def take(self, owner: str, force: bool = False) -> Request:
        """Ask for the token: granted at once when free, else a pending Request (one at a
        time: a newer one replaces it)."""
        if not isinstance(owner, str) or not owner:
            raise DeskRefusal(400, "BadRequest", f"owner {owner!r}: expected the requester's "
                              "name, a non-empty string")
        request = Request(self._issue(owner), force)
        if self.token is None:
            self._grant(request)
        else:
            if self.pending is not None:
                self.pending.withdrawn = self.pending.replaced = True
            self.pending = request
        self._changed()
        return request

    def _grant(self, request: Request) -> None:
        self.token, request.granted = request.token, True
        if self.pending is request:
            self.pending = None

    def withdraw(self, request: Request) -> None:
        """A waiting take gave up (its timeout passed): it is no longer pending."""
        if self.pending is request:
            self.pending = None
            request.withdrawn = True
            self._changed()

    def release(self, secret: str | None) -> None:
        """The holder gives the token back; a pending unforced take gets it."""
        self.check_token(secret)
        self.token = None
        pending = self.pending
        if pending is not None and not pending.withdrawn:
            self._grant(pending)
        self._changed()

    def check_token(self, secret: str | None) -> Token:
        """The token a changing call presents (X-Control-Token), or the refusal."""
        import hmac

        token = self.token
        if not secret:
            raise DeskRefusal(403, "MissingControlToken",
                              "this call needs the control token (X-Control-Token)")
        if token is None or not hmac.compare_digest(secret.encode(), token.secret.encode()):
            raise DeskRefusal(403, "InvalidControlToken",
                              "the control token given is not the one that holds control")
        return token

    def press(self, button: str) -> None:
        """A Pilot button pressed and released: heard by every listener; the confirm button
        hands the token to a pending forced take (physical access shown)."""
        if button not in PILOT_BUTTONS:
            raise DeskRefusal(400, "BadRequest", f"no Pilot button {button!r} (one of "
                              f"{', '.join(PILOT_BUTTONS)})")
        for pressed in (True, False):
            for listener in list(self.listeners):
                listener({button: pressed})
        pending = self.pending
        if button == CONFIRM_BUTTON and pending is not None and pending.force:
            self._grant(pending)
        self._changed()

    # -- what the holder may change ------------------------------------------------------------------
    def set_brakes(self, secret: str | None, state: str) -> None:
        self.check_token(secret)
        self.brakes = state
        self._changed()

    def lock_brakes(self) -> None:
        """The older Desk's close-brakes: locking makes nothing move, so any logged-in user
        may (panda-python's `lock` sends no control token)."""
        self.brakes = LOCKED
        self._changed()

    def set_operating_mode(self, secret: str | None, mode: str) -> None:
        self.check_token(secret)
        if mode not in OPERATING_MODES:
            raise DeskRefusal(400, "BadRequest", f"no operating mode {mode!r} (one of "
                              f"{', '.join(OPERATING_MODES)})")
        self._check_panda_mode(mode)
        self.operating_mode = mode
        self._changed()

    def _check_panda_mode(self, mode: str | None) -> None:
        """The Panda has no Programming mode: its arm is always in Execution."""
        if mode == PROGRAMMING and self.robot == "fer":
            raise DeskRefusal(400, "BadRequest", "a Panda has no Programming mode (its arm "
                              "is in Execution; the brakes hold it)")

    def set_fci(self, secret: str | None, active: bool) -> None:
        self.check_token(secret)
        self.fci = active
        self._changed()

    def set_end_effector_power(self, secret: str | None, on: bool) -> None:
        self.check_token(secret)
        self.end_effector_powered = on
        self._changed()

    def home_gripper(self, secret: str | None) -> None:
        """The Desk's gripper homing: the Hand homes (its end effector must be powered)."""
        self.check_token(secret)
        if not self.end_effector_powered:
            raise DeskRefusal(409, "Conflict", "the end effector is not powered")
        self.gripper_homings += 1
        self._changed()

    def run_self_tests(self, secret: str | None) -> None:
        """The safety self-tests: they need the brakes closed (the robot tests them) and pass;
        the simulator has nothing that could fail them, so they end within the call."""
        self.check_token(secret)
        if self.brakes != LOCKED:
            raise DeskRefusal(424, "PreconditionFailed", "the self-tests need the brakes "
                              "locked", ("BrakesOpen",))
        self.self_tests = "Finished"
        self._changed()

    # -- outside the Desk: someone at the robot (the control API) ---------------------------------
    def set_arm(self, brakes: str | None = None, operating_mode: str | None = None) -> None:
        """Both checked before either changes."""
        if brakes is not None and brakes not in BRAKE_STATES:
            raise DeskRefusal(400, "BadRequest", f"brakes {brakes!r}: expected "
                              f"{' or '.join(BRAKE_STATES)}")
        if operating_mode is not None and operating_mode not in OPERATING_MODES:
            raise DeskRefusal(400, "BadRequest", f"operating_mode {operating_mode!r}: "
                              f"expected {' or '.join(OPERATING_MODES)}")
        self._check_panda_mode(operating_mode)
        self.brakes = brakes or self.brakes
        self.operating_mode = operating_mode or self.operating_mode
        self._changed()
