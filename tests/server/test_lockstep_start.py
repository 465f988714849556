"""A lockstep motion's start, for a client whose reads the server sees: the states it reads
before its first command go as soon as it has read each, the one it answers waits for the
answer, and it reads the same states it would have read spaced START_SPACING apart.

The robot core and the clock policy on fake time, the cycle driver on a fake thread and a
fake probe, the probe on real sockets: no test here depends on how fast this machine runs.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time

import pytest

from franka_sim.protocol.codec import decode_state
from franka_sim.protocol.enums import MoveStatus
from franka_sim.robot.world_cycle import WorldCycle
from franka_sim.server.clock import READ_MARGIN, START_SPACING, Clock, ClockWatcher
from franka_sim.server.cycle_driver import READ_POLL, CycleDriver
from franka_sim.server.pacing import LOCKSTEP_WINDOW
from franka_sim.server import read_probe
from franka_sim.server.read_probe import LOOK_BUDGET, probe_for
from franka_sim.testing import fresh_loopback_address

from support.harness import Harness

TORQUE = (2, 4)  # controller, generator of a torque-control Move


def _learned(harness: Harness, reads: int) -> None:
    """A first motion whose client answered the `reads`-th state after the first, stopped."""
    assert harness.move(*TORQUE) == MoveStatus.kMotionStarted
    first = int(harness.cycle()["message_id"])
    harness.cycle(reads)
    harness.send(message_id=first + reads, tau_J_d=[0.0] * 7)
    harness.core.request_stop(6)
    harness.cycle()


def test_the_robot_keeps_how_many_start_states_its_client_read_before_answering():
    harness = Harness()
    assert harness.core.start_reads is None  # nothing seen yet
    _learned(harness, 2)
    assert harness.core.start_reads == 2
    _learned(harness, 1)
    assert harness.core.start_reads == 1  # the last start counts
    harness.core.client_connected()
    assert harness.core.start_reads == 1  # a program's next connection starts as its last
    measured = harness.backend.measure()
    harness.core.reset(measured.q, measured)
    assert harness.core.start_reads is None  # a reset: as freshly powered up
    assert harness.move(*TORQUE) == MoveStatus.kMotionStarted
    first = int(harness.cycle()["message_id"])
    harness.send(message_id=first - 3, tau_J_d=[0.0] * 7)  # an id from before the start
    assert harness.core.start_reads is None


class _Time:
    def __init__(self) -> None:
        self.now = 0.0


def _clock(reads: int | None, seen: bool) -> tuple[Clock, _Time, list[int]]:
    """A lockstep clock on fake time at a motion's first state, its client having read
    `reads` states before answering at its last start (None: no start yet), `seen`: whether
    its reads can be seen; the message_ids sent."""
    harness, now, sent = Harness(), _Time(), []
    if reads is not None:
        _learned(harness, reads)

    def send(states) -> float:
        sent.append(int(decode_state(states[0])["message_id"]))
        return now.now

    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    clock = Clock(world, lockstep=True, send=send, post=lambda message_id, replies: None,
                  has_client=lambda: True, reads_seen=lambda robot: seen)
    clock.tick(True, False, False)
    assert harness.move(*TORQUE) == MoveStatus.kMotionStarted
    clock.client_event()  # (the Move request)
    clock.tick(True, False, False)
    assert world.first_motion_state
    return clock, now, sent


def test_each_start_state_goes_once_the_client_read_the_one_before():
    clock, now, sent = _clock(2, seen=True)
    first = sent[-1]
    for held in (1, 2):
        assert clock.awaits_read == 0  # robot 0's client is to read this state first
        assert clock.deadline == pytest.approx(now.now + LOCKSTEP_WINDOW)  # at the latest
        now.now += 0.3e-3
        assert clock.tick(False, False, True) == clock.deadline  # woken: nothing goes
        clock.client_read(now.now)
        assert clock.awaits_read is None
        assert clock.deadline == pytest.approx(now.now + READ_MARGIN)
        now.now = clock.deadline
        clock.tick(True, False, True)
        assert sent[-1] == first + held
    # The state it answers waits for its answer, a window, and reads are no longer looked for.
    assert clock.awaits_read is None
    assert clock.deadline == pytest.approx(now.now + LOCKSTEP_WINDOW)


@pytest.mark.parametrize("reads, seen", [(None, True), (2, False)])
def test_a_client_not_seen_or_not_known_gets_its_start_states_spaced(reads, seen):
    clock, now, sent = _clock(reads, seen)
    for _ in range(2):
        assert clock.awaits_read is None
        assert clock.deadline == pytest.approx(now.now + START_SPACING)
        now.now = clock.deadline
        clock.tick(True, False, True)
    assert clock.deadline == pytest.approx(now.now + LOCKSTEP_WINDOW)


def test_a_client_that_answers_the_first_held_state_is_awaited_after_it():
    clock, now, sent = _clock(1, seen=True)
    clock.client_read(now.now)
    now.now = clock.deadline
    clock.tick(True, False, True)
    assert clock.awaits_read is None
    assert clock.deadline == pytest.approx(now.now + LOCKSTEP_WINDOW)


def test_a_start_ended_while_a_read_was_awaited_leaves_no_look_behind():
    """The Desk locks the brakes (the motion aborted) or the client stops it mid-start: the
    next tick sends what is due and forgets the read, even one that pauses the clock."""
    clock, now, sent = _clock(2, seen=True)
    assert clock.awaits_read == 0
    clock.cycle.parts[0].core.request_stop(7)
    clock.client_event()
    clock.has_client = lambda: False  # and the client left
    clock.tick(False, False, True)
    assert clock.awaits_read is None
    deadline = clock.deadline
    while deadline is not None:  # the arm settles, nobody is there: the clock pauses
        now.now = deadline
        deadline = clock.tick(True, False, False)
    assert clock.paused and clock.awaits_read is None


class _Thread:
    def __init__(self) -> None:
        self.watched: list = []
        self.jobs_waiting = False

    async def call(self, fn, *args):
        return fn(None, *args)

    async def run_clock(self, tick) -> None:
        self.tick = tick

    def watch(self, sockets) -> None:
        self.watched.append(sockets)

    def wake(self) -> None:
        pass


class _Endpoint:
    def __init__(self) -> None:
        self.sock, self.faults = object(), None
        self.target = ("127.0.0.1", 40000)
        self.sent: list[int] = []

    def read(self, limit: int = 64) -> list:
        return []

    def send_state(self, data: bytes) -> None:
        self.sent.append(int(decode_state(data)["message_id"]))


class _Probe:
    table = "/nowhere/udp"  # (what a real probe reads)
    sockets = 20  # in that table

    def __init__(self) -> None:
        self.queued: int | None = 1  # bytes the client has not read (None: socket gone)

    def unread(self) -> int | None:
        return self.queued


def _driver_at_a_start(probe: _Probe) -> tuple[CycleDriver, _Thread, _Endpoint]:
    """A lockstep driver on a fake thread whose robot's client read two states before
    answering at its last start, a Move of it just admitted (its first state is next)."""
    harness, thread, endpoint = Harness(), _Thread(), _Endpoint()
    _learned(harness, 2)
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    driver = CycleDriver(lambda physics: world, thread, threading.Lock(), lockstep=True,
                         deliver=lambda replies, clients: None, clients=lambda: None,
                         has_client=lambda: True, watcher=ClockWatcher(),
                         find_probe=lambda target: probe)
    asyncio.run(driver.start([endpoint]))
    thread.tick(None, True)
    assert harness.move(*TORQUE) == MoveStatus.kMotionStarted
    driver.client_event()
    return driver, thread, endpoint


def test_the_driver_looks_at_the_clients_socket_until_it_read_the_state():
    probe = _Probe()
    driver, thread, endpoint = _driver_at_a_start(probe)
    before = time.monotonic()
    deadline = thread.tick(None, True)  # the motion's first state
    assert driver.clock.awaits_read == 0
    assert deadline <= time.monotonic() + READ_POLL  # it looks again soon
    first = len(endpoint.sent)
    for _ in range(3):  # unread: nothing goes, however often it looks
        deadline = thread.tick(None, True)
        assert len(endpoint.sent) == first and thread.watched[-1] == (endpoint.sock,)
    probe.queued = 0  # read
    deadline = thread.tick(None, True)
    assert len(endpoint.sent) == first  # READ_MARGIN after the read
    assert deadline == driver.clock.deadline >= before + READ_MARGIN  # no sooner look
    time.sleep(READ_MARGIN)
    thread.tick(None, True)
    assert endpoint.sent[first:] == [endpoint.sent[first - 1] + 1]  # the first held state
    assert driver.clock.awaits_read == 0
    probe.queued = None  # the client's socket closed: spaced as an unseen client's
    thread.tick(None, True)
    assert driver.clock.awaits_read is None and len(endpoint.sent) == first + 1
    assert driver.clock.deadline <= time.monotonic() + START_SPACING


class _SlowProbe(_Probe):
    """A look at a table of thousands of sockets."""

    def unread(self) -> int | None:
        time.sleep(2 * LOOK_BUDGET)
        return self.queued


def test_a_look_that_takes_too_long_ends_looking_at_that_client():
    driver, thread, _ = _driver_at_a_start(_SlowProbe())
    thread.tick(None, True)  # the motion's first state: its read awaited
    assert driver.clock.awaits_read == 0
    thread.tick(None, True)  # the look took too long: no more looks at this client
    assert driver.clock.awaits_read is None and not driver._reads_seen(0)
    assert driver.clock.deadline <= time.monotonic() + START_SPACING


def test_faults_on_the_link_make_the_reads_unseen():
    harness, thread, endpoint = Harness(), _Thread(), _Endpoint()
    world = WorldCycle([harness.robot_cycle], harness.backend.world.step)
    driver = CycleDriver(lambda physics: world, thread, threading.Lock(), lockstep=True,
                         deliver=lambda replies, clients: None, clients=lambda: None,
                         has_client=lambda: True, watcher=ClockWatcher(),
                         find_probe=lambda target: _Probe())
    asyncio.run(driver.start([endpoint]))
    assert driver._reads_seen(0)
    endpoint.faults = object()  # a held state would reach the client later than it left
    assert not driver._reads_seen(0)


@pytest.mark.parametrize("bound_to", ["host", "any"])
def test_the_probe_sees_a_loopback_clients_unread_datagrams(bound_to, monkeypatch):
    monkeypatch.setattr(read_probe, "LOOK_BUDGET", 60.0)  # (whatever this machine's load)
    host = fresh_loopback_address()
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    with client, sender:
        client.bind((host if bound_to == "host" else "0.0.0.0", 0))
        target = (host, client.getsockname()[1])
        probe = probe_for(target)
        assert probe is not None and probe.unread() == 0
        sender.sendto(b"x" * 100, target)
        sender.sendto(b"y" * 100, target)
        assert probe.unread() > 0
        client.recv(200)
        assert probe.unread() > 0  # one of the two is still there
        client.recv(200)
        assert probe.unread() == 0
    assert probe.unread() is None  # closed


@pytest.mark.parametrize("sockets", [3, read_probe.CROWDED + 1])
def test_a_crowded_table_too_slow_to_read_is_not_read_again(sockets, tmp_path, monkeypatch):
    """A slow look at a crowded table: each new connection's first look would hold the cycle
    thread as long, so none is made. A small one read slowly: the machine was busy, the next
    connection's client is looked for."""
    table = tmp_path / "udp"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        client.bind(("127.0.0.1", 0))
        target = ("127.0.0.1", client.getsockname()[1])
        port = f"{target[1]:04X}"
        rows = [f"   0: 0100007F:{port} 00000000:0000 07 00000000:00000000\n"] + [
            f"{k:4d}: 0100007F:0001 00000000:0000 07 00000000:00000000\n"
            for k in range(1, sockets)]
        table.write_text("  sl  local_address rem_address   st tx_queue rx_queue\n"
                         + "".join(rows))
        monkeypatch.setattr(read_probe, "LOOK_BUDGET", -1.0)  # every look too slow
        assert probe_for(target, table=str(table)) is None
        monkeypatch.setattr(read_probe, "LOOK_BUDGET", 60.0)
        probe = probe_for(target, table=str(table))
        assert (probe is None) == (sockets > read_probe.CROWDED)
        assert probe is None or probe.sockets == sockets


def test_a_client_the_probe_cannot_see_has_none():
    assert probe_for(("192.0.2.7", 40000)) is None  # not on this host's loopback
    assert probe_for(("::1", 40000)) is None
    assert probe_for(None) is None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind((fresh_loopback_address(), 0))
        port = s.getsockname()[1]
    assert probe_for(("127.0.0.1", port)) is None  # no socket there
