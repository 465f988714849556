"""Replay: the recorded run again, in a fresh simulator without sockets, compared bit for bit.

The world is built from the recording's configuration exactly as `franka-sim serve` builds it
(assembly.WorldParts): every robot of it, arms and mobile base. Then every recorded event that
could change it (a RobotCommand handed to a robot, TCP bytes from a client, its connect and
disconnect, a control operation) is applied at the point of the cycle sequence where it was
recorded: after the release of cycle n, before or after that cycle's completion. The cycles
between are released and completed as the server does (robot/world_cycle.py): stepped, or, where
the recording says the server left the world as it was (lockstep's idle time, a motion's start
held for its client's first command), repeated. Each state the server sent is compared with the
replayed one, and so is each tool state it sent (the Hand's, the vacuum gripper's: by
message_id, as lockstep's settling sends only its last cycle's). Cycles whose states were not
sent (no client yet, lockstep's settling) are released all the same.

A recording started on a running server (the control API's `/recording`) begins with the reset
it started from, at cycle n: the fresh simulator's clock is moved to n and that reset is
replayed there. A reset world is a fresh one at a later message_id (the reset puts back every
state the robot, the Hand and the physics keep), so from then on the run is replayed as any
other.
"""

from __future__ import annotations

import bisect
import tempfile
import threading
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from franka_sim.control.errors import ControlError
from franka_sim.operations.arm import ArmOps
from franka_sim.control.table import BY_NAME, Effect
from franka_sim.protocol.codec import STATE_DTYPE
from franka_sim.protocol.gripper_messages import GripperState
from franka_sim.protocol.vacuum_gripper_messages import VacuumGripperState
from franka_sim.recording.channels import TOOL_STATE_KEYS
from franka_sim.playback.recorded_world import recorded_physics
from franka_sim.recording.metadata import START_FRESH, START_RESET, Incompatible
from franka_sim.recording.reader import Recording, command_of, tcp_data
from franka_sim.robot.session import SessionError


@dataclass
class Outcome:
    cycles: int = 0  # cycles whose recorded states (every robot's) were compared
    tool_states: int = 0  # recorded tool states (the Hand's, the vacuum gripper's) compared
    divergence: int | None = None  # the first cycle that differs
    fields: list[str] = field(default_factory=list)  # what differs there
    note: str = ""
    cut: int | None = None  # `until`, where it left out a state the recording holds

    @property
    def identical(self) -> bool:
        return self.divergence is None

    def line(self) -> str:
        if self.identical:
            if not self.cycles and not self.tool_states:
                why = ("no client was sent a state" if self.cut is None
                       else f"no state was sent by cycle {self.cut}")
                return f"identical (0 cycles: {why}, so nothing was compared)"
            tools = f", {_counted(self.tool_states, 'tool state')}" if self.tool_states else ""
            return f"identical ({_counted(self.cycles, 'cycle')}{tools})"
        return f"diverged at cycle {self.divergence}: {', '.join(self.fields)}" + (
            f" ({self.note})" if self.note else "")


def _counted(n: int, what: str) -> str:
    return f"{n} {what}" + ("" if n == 1 else "s")


def differing_fields(recorded: bytes, replayed: bytes | None) -> list[str]:
    if replayed is None:
        return ["(no state: packing failed)"]
    a, b = np.frombuffer(recorded, STATE_DTYPE)[0], np.frombuffer(replayed, STATE_DTYPE)[0]
    return [name for name in STATE_DTYPE.names
            if a[name].tobytes() != b[name].tobytes()]


_REPLAYED = ("robot_state", "command", "tcp", "control")  # the events replay applies
_TOOL_STATES = {"gripper_state": GripperState, "vacuum_gripper_state": VacuumGripperState}
assert set(_TOOL_STATES) == set(TOOL_STATE_KEYS.values())


def differing_tool_fields(key: str, recorded: bytes, replayed: bytes) -> list[str]:
    layout = _TOOL_STATES[key]
    a, b = layout.parse(recorded), layout.parse(replayed)
    return [name for name in a if not name.startswith("_") and a[name] != b[name]] or [key]


class _Diverged(Exception):
    pass


class Replayer:
    def __init__(self, recording: Recording) -> None:
        # Holds a recorded URDF or scene whose path is gone; removed with the replayer.
        self._workdir = tempfile.TemporaryDirectory(prefix="franka-sim-replay-")
        # The world and each robot's body in it (Incompatible: it cannot be built here).
        self.config, self.world_parts, self.physics = recorded_physics(
            recording, self._workdir.name)
        parts = self.world_parts
        self.recording = recording
        self.listening = [False] * len(parts.robots)  # a Hand client took its state stream
        # Each robot's tool states, by message_id, not yet compared: replayed (the server sent
        # only some: lockstep's settling sends the last cycle's alone), and recorded ahead of
        # the replay (a tool state goes once its cycle is completed).
        self.replayed_tools = [deque() for _ in parts.robots]
        self.recorded_tools = [deque() for _ in parts.robots]
        self.cycle = parts.make_cycle(
            self.physics, [lambda i=i: self.listening[i] for i in range(len(parts.robots))])
        self.released = None  # the cycle released and not completed, if any
        self.sessions: dict = {}  # (robot, service): the client's session
        runs = sorted((e.json()["first"], e.json()["last"]) for e in recording.of("repeated"))
        self._repeat_firsts = [first for first, _ in runs]
        self._repeat_runs = runs
        # first id -> how many: the cycles the server's clock moved on over with no state
        self._skips = {e.json()["first"]: e.json()["last"] - e.json()["first"] + 1
                       for e in recording.of("skipped")}
        self.ops = {i: ArmOps(
            core=arm.core, tool=arm.tool, driver=_Driver(self), worker=_Worker(self),
            lock=threading.Lock(), description=arm.description, q0=arm.q0,
            clock=self.config.clock.value, arm=arm.name, arm_index=i,
            client_connected=lambda i=i: (i, "robot") in self.sessions,
            desk_boot=self.config.desk_boot)
            for i, arm in enumerate(parts.robots) if arm.kind == "arm"}

    # -- the cycle sequence ------------------------------------------------------------------------
    def advance(self, n: int, completed: bool) -> None:
        """Release and complete cycles until cycle n is released (and completed, if asked)."""
        cycle = self.cycle
        while True:
            here = cycle.message_id
            done = self.released is None
            if (here, done) == (n, completed):
                return
            if (here, done) > (n, completed):
                raise _Diverged(f"an event recorded at cycle {n} comes after cycle {here}")
            if not done:
                replies = cycle.complete(self.released)
                self.released = None
                for robot, robot_replies in enumerate(replies.robots):
                    for _, tool_state in robot_replies.tools:
                        if tool_state is not None:
                            self.replayed_tools[robot].append(
                                (int.from_bytes(tool_state[:4], "little"), tool_state))
            elif here + 1 in self._skips:
                cycle.skip(self._skips[here + 1])
            elif self._repeated(here + 1):
                self.released = (cycle.hold() if cycle.holds_start else None) or cycle.repeat()
            else:
                self.released = cycle.release()

    def _repeated(self, n: int) -> bool:
        """The server left the world as it was in cycle n (its recorded runs)."""
        k = bisect.bisect_right(self._repeat_firsts, n) - 1
        return k >= 0 and self._repeat_runs[k][1] >= n

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
        for part in self.cycle.parts:
            part.core.message_id = part.completed_id = start

    def run(self, until: int | None = None) -> Outcome:
        self.start_where_recorded()
        outcome, compared = Outcome(), None
        try:
            entries = self.recording.entries
            for k, entry in enumerate(entries):
                key, robot = entry.key, entry.robot
                if key == "robot_state":
                    n = int.from_bytes(entry.data[:8], "little")  # its message_id
                    if until is not None and n > until:  # (a tool state up to it may follow)
                        self._record_tools(entries[k:], until)
                        outcome.cut = until
                        break
                    self.advance(n, False)
                    replayed = self.released.robots[robot].state
                    if replayed != entry.data:
                        outcome.divergence = n
                        outcome.fields = differing_fields(entry.data, replayed)
                        if len(self.recording.robots) > 1:
                            outcome.note = f"robot {self.recording.robots[robot]}"
                        return outcome
                    if n != compared:
                        outcome.cycles, compared = outcome.cycles + 1, n
                elif key == "command":
                    n, completed, on_time, command = command_of(entry)
                    self.advance(n, completed)
                    if self.cycle.parts[robot].receive(command) != on_time:
                        outcome.divergence, outcome.fields = n, ["command fate"]
                        outcome.note = "a command recorded " + (
                            "on time came late" if on_time else "late came on time")
                        return outcome
                elif key == "tcp":
                    self._tcp(robot, entry.json())
                elif key == "control":
                    self._control(robot, entry.json())
                elif key in _TOOL_STATES:
                    self._record_tools((entry,), until)
                if self._tools_differ(outcome):
                    return outcome
            self._last_tool_states(outcome)
        except _Diverged as exc:
            outcome.divergence = self.cycle.message_id
            outcome.fields, outcome.note = ["event order"], str(exc)
        return outcome

    def _record_tools(self, entries, until: int | None) -> None:
        for entry in entries:
            if entry.key in _TOOL_STATES:
                n = int.from_bytes(entry.data[:4], "little")
                if until is None or n <= until:
                    self.recorded_tools[entry.robot].append((n, entry.key, entry.data))

    def _tools_differ(self, outcome: Outcome) -> bool:
        """Compare each recorded tool state with the replayed one of its message_id, once the
        replay has sent it."""
        for robot, (recorded, replayed) in enumerate(zip(self.recorded_tools,
                                                         self.replayed_tools)):
            while recorded and replayed:
                n, key, data = recorded[0]
                if replayed[0][0] != n:
                    replayed.popleft()  # a tool state the server did not send
                    continue
                recorded.popleft()
                again = replayed.popleft()[1]
                if data != again:
                    outcome.divergence, outcome.fields = n, differing_tool_fields(key, data, again)
                    outcome.note = f"{key} of robot {self.recording.robots[robot]}"
                    return True
                outcome.tool_states += 1
        return False

    def _last_tool_states(self, outcome: Outcome) -> None:
        """After the last event: run on to the cycles of the tool states recorded last, then
        any recorded tool state the replay did not send is a divergence."""
        last = max((recorded[-1][0] for recorded in self.recorded_tools if recorded), default=None)
        if last is not None and (self.cycle.message_id, self.released is None) < (last, True):
            self.advance(last, True)
        if self._tools_differ(outcome):
            return
        for robot, recorded in enumerate(self.recorded_tools):
            if recorded:
                n, key, _ = recorded[0]
                outcome.divergence, outcome.fields = n, [f"{key} (not sent in the replay)"]
                outcome.note = f"robot {self.recording.robots[robot]}"
                return

    def _tcp(self, robot: int, event: dict) -> None:
        self.advance(event["cycle"], event["completed"])
        service, kind = event["service"], event["event"]
        parts = self.world_parts.robots[robot]
        if kind == "open":
            self.sessions[robot, service] = (parts.robot_session() if service == "robot"
                                             else parts.tool_session())
        elif kind == "close":
            self.sessions.pop((robot, service), None)
            if service == "robot":
                parts.core.client_gone()
            else:
                self.listening[robot] = False
                parts.tool.client_gone()
        else:
            session = self.sessions[robot, service]
            had_handshake = session.handshake is not None
            try:
                session.feed(tcp_data(event))
            except SessionError:
                pass  # the server closed that connection: its close follows
            if not had_handshake and session.handshake is not None:
                if service == "robot":
                    parts.core.client_connected()
                else:
                    self.listening[robot] = True

    def _control(self, robot: int, call: dict) -> None:
        self.advance(call["cycle"], call["completed"])
        operation, args = call["operation"], call["arguments"]
        if operation not in BY_NAME or BY_NAME[operation].effect is not Effect.CHANGE:
            raise Incompatible(f"a recorded control call {operation!r} is not an operation "
                               "that changes the world (control/table.py)")
        status = _run_now(getattr(self.ops[robot], operation)(**args))
        if status != call["status"]:
            raise _Diverged(f"control {operation} answered {status}, recorded {call['status']}")


def _run_now(coroutine) -> int:
    """An operation's status, run to its end at once: the replayed worker runs each job in
    line, so an operation never waits on anything."""
    try:
        coroutine.send(None)
    except StopIteration:
        return 200
    except ControlError as refusal:
        return refusal.status
    raise RuntimeError("a control operation suspended in replay")


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
    """What the control operations ask of the world's clock."""

    def __init__(self, replayer: Replayer) -> None:
        self.replayer = replayer

    def withdraw_prepared(self) -> int | None:
        replayer = self.replayer
        if replayer.released is None:
            return None
        replayer.released = None  # released ahead, never sent: taken back
        last = replayer.cycle.message_id - 1
        replayer.cycle.rewind(last)
        return last

    def keep_running(self, cycles: int = 0) -> None:
        pass


def replay(recording: Recording, until: int | None = None) -> Outcome:
    return Replayer(recording).run(until)
