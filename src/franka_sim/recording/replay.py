"""Replay: the recorded run again, in a fresh simulator without sockets, compared bit for bit.

The robot is built from the recording's configuration exactly as `franka-sim serve` builds it
(assembly.WorldParts). Then every recorded event that could change it (a RobotCommand handed to
the core, TCP bytes from a client, its connect and disconnect, a control operation) is applied
at the point of the cycle sequence where it was recorded: after the release of cycle n, before
or after that cycle's completion. The cycles between are released and completed as the server
does (RobotCycle); each state the server sent is compared with the replayed one. Cycles whose
states were not sent (no client yet, lockstep's settling) are released all the same; lockstep's
idle repeats are released as steps, which at rest give the same bits.

A recording started on a running server (the control API's `/recording`, recording/live.py)
begins with the reset it started from, at cycle n: the fresh simulator's clock is moved to n
and that reset is replayed there. A reset world is a fresh one at a later message_id (the
reset puts back every state the robot, the Hand and the physics keep), so from then on the run
is replayed as any other.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from franka_sim.assembly import WorldParts
from franka_sim.control.errors import ControlError
from franka_sim.operations.arm import ControlOps
from franka_sim.operations.table import BY_NAME, Effect
from franka_sim.protocol.codec import STATE_DTYPE
from franka_sim.recording.live import START_FRESH, START_RESET
from franka_sim.recording.metadata import Incompatible, replay_config
from franka_sim.recording.reader import Recording, command_of, tcp_data
from franka_sim.robot.session import SessionError


@dataclass
class Outcome:
    cycles: int = 0  # recorded states compared
    divergence: int | None = None  # the first cycle that differs
    fields: list[str] = field(default_factory=list)  # what differs there
    note: str = ""

    @property
    def identical(self) -> bool:
        return self.divergence is None

    def line(self) -> str:
        if self.identical:
            return f"identical ({self.cycles} cycles)"
        return f"diverged at cycle {self.divergence}: {', '.join(self.fields)}" + (
            f" ({self.note})" if self.note else "")


def differing_fields(recorded: bytes, replayed: bytes | None) -> list[str]:
    if replayed is None:
        return ["(no state: packing failed)"]
    a, b = np.frombuffer(recorded, STATE_DTYPE)[0], np.frombuffer(replayed, STATE_DTYPE)[0]
    return [name for name in STATE_DTYPE.names
            if a[name].tobytes() != b[name].tobytes()]


_REPLAYED = ("robot_state", "command", "tcp", "control")  # the events replay applies


class _Diverged(Exception):
    pass


class Replayer:
    def __init__(self, recording: Recording) -> None:
        self.config = replay_config(recording.metadata)
        self.recording = recording
        self.world_parts = WorldParts(self.config)
        self.parts = parts = self.world_parts.arms[0]
        self.physics = self.world_parts.make_physics()  # one backend per arm (here: one)
        self.hand_listens = False  # a Hand client took its state stream (its handshake)
        self.cycle = self.world_parts.make_cycle(self.physics, [lambda: self.hand_listens])
        self.core = parts.core
        self.released = None  # the cycle released and not completed, if any
        self.sessions: dict = {}
        self.ops = ControlOps(
            core=parts.core, gripper=parts.gripper, driver=_Driver(self), worker=_Worker(self),
            lock=threading.Lock(), description=parts.description, q0=parts.q0,
            clock=self.config.clock.value, client_connected=lambda: "robot" in self.sessions)

    # -- the cycle sequence ------------------------------------------------------------------------
    def advance(self, n: int, completed: bool) -> None:
        """Release and complete cycles until cycle n is released (and completed, if asked)."""
        core, cycle = self.core, self.cycle
        while True:
            here = core.message_id
            done = self.released is None
            if (here, done) == (n, completed):
                return
            if (here, done) > (n, completed):
                raise _Diverged(f"an event recorded at cycle {n} comes after cycle {here}")
            if done:
                self.released = cycle.release()
            else:
                cycle.complete(self.released)
                self.released = None

    # -- the events ----------------------------------------------------------------------------------
    def start_where_recorded(self) -> None:
        """Move the clock to the reset a recording started on a running server begins with."""
        if self.recording.metadata.get("start", START_FRESH) != START_RESET:
            return
        first = next((e for e in self.recording.entries if e.key in _REPLAYED), None)
        call = first.json() if first is not None and first.key == "control" else {}
        if call.get("operation") != "reset":
            raise Incompatible("a recording started on a running server begins with its "
                               "reset, and this one does not")
        # Where the server was: cycle n released, and completed or (idle, released ahead) not.
        start = call["cycle"] - (0 if call["completed"] else 1)
        self.core.message_id = self.cycle.completed_id = start

    def run(self, until: int | None = None) -> Outcome:
        self.start_where_recorded()
        outcome = Outcome()
        try:
            for entry in self.recording.entries:
                key = entry.key
                if key == "robot_state":
                    n = int.from_bytes(entry.data[:8], "little")  # its message_id
                    if until is not None and n > until:
                        break
                    self.advance(n, False)
                    if self.released.state != entry.data:
                        outcome.divergence = n
                        outcome.fields = differing_fields(entry.data, self.released.state)
                        return outcome
                    outcome.cycles += 1
                elif key == "command":
                    n, completed, on_time, command = command_of(entry)
                    self.advance(n, completed)
                    if self.cycle.receive(command) != on_time:
                        outcome.divergence, outcome.fields = n, ["command fate"]
                        outcome.note = "a command recorded " + (
                            "on time came late" if on_time else "late came on time")
                        return outcome
                elif key == "tcp":
                    self._tcp(entry.json())
                elif key == "control":
                    self._control(entry.json())
        except _Diverged as exc:
            outcome.divergence = self.core.message_id
            outcome.fields, outcome.note = ["event order"], str(exc)
        return outcome

    def _tcp(self, event: dict) -> None:
        self.advance(event["cycle"], event["completed"])
        service, kind = event["service"], event["event"]
        if kind == "open":
            self.sessions[service] = (self.parts.robot_session() if service == "robot"
                                      else self.parts.gripper_session())
        elif kind == "close":
            self.sessions.pop(service, None)
            if service == "robot":
                self.core.client_gone()
            else:
                self.hand_listens = False
                self.parts.gripper.client_gone()
        else:
            session = self.sessions[service]
            had_handshake = session.handshake is not None
            try:
                session.receive(tcp_data(event))
            except SessionError:
                pass  # the server closed that connection: its close follows
            if not had_handshake and session.handshake is not None:
                if service == "robot":
                    self.core.client_connected()
                else:
                    self.hand_listens = True

    def _control(self, call: dict) -> None:
        self.advance(call["cycle"], call["completed"])
        operation, args = call["operation"], call["arguments"]
        if operation not in BY_NAME or BY_NAME[operation].effect is not Effect.CHANGE:
            raise Incompatible(f"a recorded control call {operation!r} is not an operation "
                               "that changes the world (operations/table.py)")
        coroutine = getattr(self.ops, operation)(**args)
        try:
            coroutine.send(None)  # the fake worker never suspends: it ends here
        except StopIteration:
            status = 200
        except ControlError as refusal:
            status = refusal.status
        else:
            raise RuntimeError(f"control operation {operation} suspended in replay")
        if status != call["status"]:
            raise _Diverged(f"control {operation} answered {status}, recorded {call['status']}")


class _Worker:
    """The cycle thread's job runner, in line: a job runs at once on the replayed physics."""

    def __init__(self, replayer: Replayer) -> None:
        self.replayer = replayer

    async def call(self, fn, *args):
        result = fn(self.replayer.physics, *args)
        if isinstance(result, BaseException):
            raise result
        return result


class _Driver:
    """What the control operations ask of the cycle driver."""

    def __init__(self, replayer: Replayer) -> None:
        self.replayer = replayer

    def withdraw_prepared(self) -> int | None:
        replayer = self.replayer
        if replayer.released is None:
            return None
        replayer.released = None  # released ahead, never sent: taken back
        return replayer.core.message_id - 1

    def keep_running(self) -> None:
        pass


def replay(recording: Recording, until: int | None = None) -> Outcome:
    return Replayer(recording).run(until)
