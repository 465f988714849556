"""The control operations, one row each: the one list the HTTP routes, the Python client,
FrankaSim's methods and the mobile base's API are made from.

A row says what a caller needs to call the operation and what a server needs to serve it: its
name (the method's, on the client, on FrankaSim and on the implementation), its HTTP method
and path (`{name}` in the path: an argument taken from the path), the arguments of its JSON
body (required or optional, with the default a caller sees), what it does to the world, and
which robots have it. Adding an operation is a row here and its implementation
(operations/arm.py, operations/base.py); the rest follows (docs/architecture.md).

Standard library only, and no imports from the package: the client (franka_sim.control) reads
it without numpy or aiohttp.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from enum import Enum
from typing import Any


class Kind(Enum):
    """A robot of the world that serves a control API (its value: how a refusal names it)."""

    ARM = "arm"
    BASE = "mobile base"


class Effect(Enum):
    """What an operation does."""

    READ = "reads the world"
    CHANGE = "changes the world"  # recorded with its cycle, and what replay re-applies
    RECORDING = "starts or finishes a recording"
    FAULTS = "reads or sets the robot's network faults"
    DESK = "reads or changes the Desk (the robot's web API), not the world"


@dataclass(frozen=True)
class Arg:
    """A field of the request's JSON body; an optional one may be left out (the caller's
    `default` then; None: the implementation's own choice)."""

    name: str
    required: bool = False
    default: Any = None


def need(name: str) -> Arg:
    return Arg(name, required=True)


def may(name: str, default: Any = None) -> Arg:
    return Arg(name, default=default)


_PATH_ARG = re.compile(r"\{(\w+)\}")


@dataclass(frozen=True)
class Operation:
    name: str
    method: str  # GET, POST, PUT, DELETE
    path: str  # "/bodies/{name}": `name` is a required argument taken from the path
    effect: Effect
    kinds: frozenset[Kind]
    doc: str  # what a caller gets: the client's and FrankaSim's docstring
    body: tuple[Arg, ...] = ()
    body_optional: bool = False  # an empty request body is {} (else: refused)
    collect: str | None = None  # the body's fields reach the implementation as one dict
    answer_key: str | None = None  # the HTTP answer is {answer_key: result}
    path_args: tuple[str, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "path_args", tuple(_PATH_ARG.findall(self.path)))

    @property
    def arguments(self) -> tuple[Arg, ...]:
        """What a caller of the client passes: the path's arguments, then the body's."""
        return tuple(need(name) for name in self.path_args) + self.body

    @property
    def parameters(self) -> tuple[Arg, ...]:
        """What the implementation takes: the path's arguments, then the body's fields (or
        the one dict `collect` names)."""
        body = (need(self.collect),) if self.collect is not None else self.body
        return tuple(need(name) for name in self.path_args) + body

    @property
    def fields(self) -> dict[str, bool]:
        """The body's fields: name → required."""
        return {arg.name: arg.required for arg in self.body}

    def where(self, **path_args: str) -> str:
        """The path with its arguments put in (as given: quoting is the caller's)."""
        return _PATH_ARG.sub(lambda m: path_args[m.group(1)], self.path)


ARM, BOTH = frozenset({Kind.ARM}), frozenset({Kind.ARM, Kind.BASE})
FAULT_FIELDS = ("spec", "loss", "delay", "jitter", "burst", "reorder", "dir", "seed")

OPERATIONS: tuple[Operation, ...] = (
    Operation(
        "health", "GET", "/health", Effect.READ, BOTH,
        """{"ready", "arm" (the base: "mobile_base"), "clock", "cycle", "client_connected",
        "robot_mode"}: cheap, for probes. Failed (503) once the simulator stopped simulating,
        with the reason."""),
    Operation(
        "state", "GET", "/state", Effect.READ, BOTH,
        """The ground truth now: q, dq, tau_J, O_T_EE (4×4, rows), robot_mode, errors (names),
        success_rate, gripper_width and gripper_busy (an action, a homing too, under way;
        None without a Hand), vacuum_gripper (None without one:
        its vacuum, setpoint, in_control_range, part_present, part_detached, device_status,
        actual_power and the part it holds), cycle. The mobile base: q, dq
        (its 4 joints), pose {x, y, yaw}, twist {vx, vy, wz}, robot_mode, cycle."""),
    Operation(
        "reset", "POST", "/reset", Effect.CHANGE, ARM,
        """Arm at rest at q (None: the start pose), errors cleared, Idle, objects back where
        they started, Hand open (or `gripper_width` apart). Conflict while a motion runs.""",
        body=(may("q"), may("gripper_width")), body_optional=True),
    Operation(
        "bodies", "GET", "/bodies", Effect.READ, ARM,
        """The world's bodies: [{"name", "free"}], a free body being one `set_pose` can
        move.""",
        answer_key="bodies"),
    Operation(
        "pose", "GET", "/bodies/{name}", Effect.READ, ARM,
        """{"position", "quaternion" (w, x, y, z), "linear_velocity", "angular_velocity",
        "free"} of a body, in the world (= the robot's base) frame."""),
    Operation(
        "set_pose", "PUT", "/bodies/{name}", Effect.CHANGE, ARM,
        """Put a free body at `position`, turned to `quaternion` (w, x, y, z; None: as it is),
        at rest. Returns its pose.""",
        body=(need("position"), may("quaternion"))),
    Operation(
        "push", "POST", "/push", Effect.CHANGE, ARM,
        """Push `body` with `force` (N) and `torque` (Nm), base frame, at its centre of mass,
        for `duration` seconds of simulated time. Returns {"body", "force", "torque",
        "cycles"}.""",
        body=(need("body"), need("force"), may("torque"), may("duration", 0.1))),
    Operation(
        "start_recording", "POST", "/recording", Effect.RECORDING, ARM,
        """Reset the world (as `reset()`) and record everything from there into `path`, an
        MCAP file on the server's machine (relative: to the server's working directory).
        Returns {"path", "cycle"}. Conflict while a recording runs or a client is
        connected.""",
        body=(need("path"),)),
    Operation(
        "finish_recording", "DELETE", "/recording", Effect.RECORDING, ARM,
        """End the recording `start_recording` began; once this returns the file is complete.
        Returns {"path", "cycle", "dropped"} (events the recorder could not keep up with)."""),
    Operation(
        "desk", "GET", "/desk", Effect.DESK, ARM,
        """The Desk's state (docs/desk.md): {"brakes", "operating_mode", "fci",
        "end_effector_power", "control_token" ({"owner", "id"} or None), "pending_request"
        ({"owner", "id", "force"} or None), "self_tests", "arm_ready"}."""),
    Operation(
        "press_pilot_button", "POST", "/desk/pilot", Effect.DESK, ARM,
        """Press and release a Pilot button (circle, cross, check, up, down, left, right), as
        someone at the robot: Desk clients listening hear it, and `circle` confirms a pending
        forced control-token take. Returns what `desk()` does.""",
        body=(need("button"),)),
    Operation(
        "desk_arm", "PUT", "/desk/arm", Effect.CHANGE, ARM,
        """Set the brakes ("Locked", "Unlocked") and the operating mode ("Programming",
        "Execution") as at the robot, without the control token (the Desk's own calls land
        here too): an arm not unlocked in Execution reads as robot mode Other and refuses
        motions. Returns what `desk()` does.""",
        body=(may("brakes"), may("operating_mode"))),
    Operation(
        "home_gripper", "POST", "/gripper/homing", Effect.CHANGE, ARM,
        """Home the Franka Hand as the Desk's homing does, no client needed (the Desk's own
        call lands here). Returns {"homing": true} once it has started; Conflict while a Hand
        action (a client's, or a homing) runs, NotFound without a Hand (--tool none)."""),
    Operation(
        "faults", "GET", "/faults", Effect.FAULTS, BOTH,
        """The network faults injected on this robot's UDP path: {"spec", "fields", "seed",
        "states", "commands", ...}, the last two counting what was seen, dropped, delayed,
        reordered and is held now."""),
    Operation(
        "set_faults", "POST", "/faults", Effect.FAULTS, BOTH,
        """Inject faults on this robot's path from the next datagram on: a spec
        ("loss=0.01,delay=2ms") or its fields (loss=0.01, delay="2ms", burst="25@3s",
        reorder=..., dir="commands"), not both; `seed`: the server's --seed when None.
        Returns what `faults()` does.""",
        body=tuple(may(name) for name in FAULT_FIELDS), collect="fields"),
    Operation(
        "clear_faults", "DELETE", "/faults", Effect.FAULTS, BOTH,
        """Inject nothing more on this robot's path; returns what the faults did."""),
)

BY_NAME = {operation.name: operation for operation in OPERATIONS}


def served_by(kind: Kind) -> tuple[Operation, ...]:
    """The rows a robot of this kind serves, in the table's order."""
    return tuple(operation for operation in OPERATIONS if kind in operation.kinds)
