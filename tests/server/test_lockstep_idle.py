"""Lockstep's idle time, on the clock policy with fake time: it follows the client's events,
not the wall clock, so a program reproduces to the bit however long the client pauses.

No sockets and no threads: the clock's tick is called by hand, wall time is a number, and what
it sends and posts is recorded (server/clock.py says what a tick does).
"""

from __future__ import annotations

import struct

import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.protocol.enums import Command, GripperCommand, GripperStatus, MoveStatus
from franka_sim.protocol.framing import Frame, decode_request
from franka_sim.protocol.gripper_messages import GRIPPER_REQUEST_STRUCTS, build_gripper_request
from franka_sim.robot.hand import Hand
from franka_sim.robot.arm_cycle import ArmCycle
from franka_sim.robot.world_cycle import WorldCycle
from franka_sim.server.clock import IDLE_QUANTUM, TREMBLE_CYCLES, Clock
from franka_sim.server.pacing import LOCKSTEP_WINDOW, PERIOD

from support.harness import Harness, reply_status

DESC = load_arm_description(default_urdf_text())


class _WallTime:
    """Wall time that moves 1 µs per reading (a state leaving reads it), and as the test says."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1e-6
        return self.now


class Rig:
    """A lockstep clock ticking a harness's arm (with the Hand) as a world of one, its states
    and replies."""

    def __init__(self, hand: bool = False) -> None:
        self.harness = Harness()
        if hand:
            self.harness.backend = MujocoBackend(DESC, self.harness.core.drives.q_hold,
                                                 scene_xml=default_scene_path(), tool=FINGERS)
            self.harness.robot_cycle.tool = Hand()
        self.wall = _WallTime()
        self.states: list[bytes] = []
        self.delivered: list[tuple[int, object]] = []  # (last message_id sent, replies)
        self.on_socket: list[bytes] = []
        self.ticks: list[tuple[int, int]] = []  # (cycles released, states sent) by each tick
        self.world = WorldCycle([self.harness.robot_cycle], self.harness.backend.world.step)
        self.clock = Clock(self.world, lockstep=True, send=self._send, post=self._post,
                           has_client=lambda: True)
        self.skipped = 0  # ids the clock moved on over with no state (idle gaps rounded up)
        self.clock.watcher.skipped = self._skipped

    def _skipped(self, cycles: int) -> None:
        self.skipped += cycles

    def _send(self, states: tuple) -> float:
        self.states.append(states[0])
        return self.wall()

    def _post(self, message_id: int, replies) -> None:
        if replies:
            self.delivered.append((message_id, replies.robots[0]))

    @property
    def cycle(self):
        return self.harness.robot_cycle

    @property
    def message_id(self) -> int:
        return int(decode_state(self.states[-1])["message_id"])

    def tick(self, due: bool) -> float | None:
        """The cycle thread's tick: the answers that came, handed to the world, then the clock."""
        cycles, states = self.cycle.message_id - self.skipped, len(self.states)
        awaited = self.clock.answer_awaited
        answered = False
        while self.on_socket:
            answered = self.world.receive(0, decode_command(self.on_socket.pop(0))) or answered
        deadline = self.clock.tick(due, answered, awaited)
        self.ticks.append((self.cycle.message_id - self.skipped - cycles,
                           len(self.states) - states))
        return deadline

    def event(self) -> float | None:
        """A client request (robot or Hand) has been handled: it wakes the clock."""
        self.clock.client_event()
        return self.tick(False)

    def wait(self, seconds: float) -> None:
        """The client takes `seconds` of wall time: every deadline in it comes."""
        end = self.wall.now + seconds
        while True:
            deadline = self.clock.deadline
            if deadline is None or deadline > end:
                break
            self.wall.now = deadline
            self.tick(True)
        self.wall.now = end

    def motion(self, velocities) -> None:
        """A joint-velocity Move answered cycle by cycle, the last command finishing it."""
        assert self.harness.move(0, 1) == MoveStatus.kMotionStarted
        self.event()  # the Move's request releases the motion's first state
        for k, dq in enumerate(velocities):
            self.on_socket.append(encode_command(
                message_id=self.message_id, dq_c=list(dq),
                motion_generation_finished=k == len(velocities) - 1))
            self.tick(False)  # the answer woke it


def _swing(n: int = 300) -> list[np.ndarray]:
    return [np.full(7, 0.3) * np.sin(np.pi * k / n) for k in range(1, n + 1)]


def test_after_a_motion_the_arm_settles_in_the_same_tick_and_the_reply_waits_for_rest():
    rig = Rig()
    rig.motion(_swing())
    cycles, states = rig.ticks[-1]
    assert cycles > 100  # the finishing answer's tick ran the arm to rest
    assert states == 2  # the first idle state, and the one at rest: none in between
    assert rig.cycle.at_rest and rig.message_id == rig.cycle.message_id
    message_id, replies = rig.delivered[-1]
    assert message_id == rig.message_id  # after the state at rest, not the motion's last
    assert [reply_status(r) for r in replies.robot] == [(Command.Move, 5, MoveStatus.kSuccess)]
    assert rig.clock.deadline == pytest.approx(rig.wall.now + LOCKSTEP_WINDOW)


def test_at_rest_the_clock_holds_for_the_client_then_ticks_on_the_wall_clock():
    rig = Rig()
    rig.motion(_swing())
    at_rest = rig.message_id
    measured = rig.cycle.core.measured
    assert rig.tick(False) is not None and rig.message_id == at_rest  # a wake alone: nothing
    rig.event()  # a request: its cycle goes at once, and the clock holds again
    assert rig.message_id == at_rest + 1
    assert rig.clock.deadline == pytest.approx(rig.wall.now + LOCKSTEP_WINDOW)
    rig.wait(LOCKSTEP_WINDOW + 10.5 * PERIOD)  # then 1 kHz, 11 cycles in the rest of the wait
    assert rig.message_id == at_rest + 1 + 11
    assert rig.cycle.core.measured is measured  # cycles that changed nothing but message_id


def _program(rig: Rig, pauses: tuple[float, float]) -> bytes:
    """Two motions and a set command with pauses of the client's in between; the last state."""
    rig.motion(_swing())
    rig.wait(pauses[0])
    rig.event()  # e.g. SetCollisionBehavior: its cycle, and its reply after it
    rig.wait(pauses[1])
    rig.motion(_swing(200)[::-1] + [np.zeros(7)])
    return rig.states[-1]


def test_a_program_ends_in_the_same_bits_however_long_the_client_paused():
    quick = _program(Rig(), (0.0, 0.0))
    slow = _program(Rig(), (0.05, 1.3))
    assert quick[8:] == slow[8:]  # everything but message_id
    later = int(decode_state(slow)["message_id"]) - int(decode_state(quick)["message_id"])
    assert later == 2 * IDLE_QUANTUM  # 1.2 s past the window: two whole quanta of idle time


def test_every_message_id_is_the_same_whichever_pause_within_the_quantum():
    """A pause within the window, and pauses past it that the quantum rounds up alike, give
    the same message_id to every state of the motion after them, not only the same bits."""
    def last_motion(pauses):
        rig = Rig()
        rig.motion(_swing())
        rig.wait(pauses[0])
        rig.event()
        frozen = rig.message_id
        rig.wait(pauses[1])
        idle_states, last_idle = len(rig.states), rig.message_id
        rig.motion(_swing(200))
        return idle_states, last_idle, frozen, [int(decode_state(state)["message_id"])
                                                for state in rig.states[idle_states:]]

    (shorter, last_idle, frozen, ids), (longer, later_idle, _, later_ids) = (
        last_motion((0.02, 0.3)), last_motion((0.05, 0.9)))
    assert longer > shorter + 500  # the longer pause saw more idle states go by,
    assert later_idle > last_idle  # and the last of them had a later message_id,
    assert later_ids == ids and len(ids) > 200  # yet the motion after it is numbered alike:
    assert ids[0] == frozen + IDLE_QUANTUM + 1  # from one quantum after the pause began


def _gripper_move(width: float) -> object:
    data = build_gripper_request(GripperCommand.Move, 7, width=width, speed=0.1)
    return decode_request(Frame(int(GripperCommand.Move), 7, data), GRIPPER_REQUEST_STRUCTS)


def test_a_hand_action_runs_on_the_wall_clock_and_the_fingers_settle_before_its_reply():
    """A client may watch a Hand action and stop it, so it takes its time as in realtime; its
    end, and the fingers settling, are one tick, and the reply follows the state at rest."""
    rig = Rig(hand=True)
    rig.event()
    rig.wait(1.0)
    hand = rig.cycle.tool
    assert rig.cycle.tool.request(GripperCommand.Move, 7, _gripper_move(0.04)) == []
    rig.event()
    rig.wait(0.3)  # 4 cm at 0.1 m/s: 0.4 s
    assert not hand.idle and set(rig.ticks[-250:]) == {(1, 1)}  # a state each ms
    rig.wait(0.2)
    assert hand.idle and rig.cycle.at_rest
    assert max(rig.ticks[-200:])[0] > 10  # the fingers' settling, in one tick
    [(message_id, replies)] = [(m, r) for m, r in rig.delivered if r.tools and r.tools[0][0]]
    assert [struct.unpack("<HIIH", r) for r in replies.tools[0][0]] == [
        (GripperCommand.Move, 7, 12, GripperStatus.kSuccess)]
    [after] = [decode_state(state) for state in rig.states
               if int(decode_state(state)["message_id"]) == message_id]
    assert not after["dq"].any()  # the reply followed the state at rest
    assert abs(hand.width - 0.04) < 5e-4


def _gripper(command: GripperCommand, **fields) -> object:
    data = build_gripper_request(command, 8, **fields)
    return decode_request(Frame(int(command), 8, data), GRIPPER_REQUEST_STRUCTS)


@pytest.mark.parametrize("then_open", [False, True], ids=["homing", "homing, then a move to max_width"])
def test_after_homing_the_fingers_come_to_rest_clear_of_their_stops(then_open):
    """Held at the opening homing measured while pressing its stops, the fingers would press
    them for ever and never come to rest; the Hand holds them a hair inside."""
    rig = Rig(hand=True)
    rig.event()
    hand = rig.cycle.tool
    hand.request(GripperCommand.Homing, 8, _gripper(GripperCommand.Homing))
    rig.event()
    rig.wait(2.0)
    if then_open:
        hand.request(GripperCommand.Move, 8, _gripper(GripperCommand.Move, width=0.04,
                                                      speed=0.1))
        rig.event()
        rig.wait(1.0)
        hand.request(GripperCommand.Move, 8, _gripper(GripperCommand.Move, width=hand.max_width,
                                                      speed=0.1))
        rig.event()
        rig.wait(1.0)
    assert rig.cycle.at_rest and not rig.clock._trembling
    assert hand.width == pytest.approx(hand.max_width, abs=1e-5)


def test_a_world_that_only_trembles_is_left_as_it_is_while_the_client_is_away(monkeypatch):
    """A grasped object's contacts tremble for ever at ~1e-6 rad/s, so that world never comes
    to rest. With nothing under way it gets TREMBLE_CYCLES to settle after each event; then,
    while the client is away, its states go out unchanged but for message_id. A client
    connecting then costs its own cycle only (2000 more, no state sent meanwhile, and a new
    Gripper's first read timed out); a request or a change gets them again."""
    rig = Rig()
    rig.event()
    rig.wait(1.0)
    monkeypatch.setattr(ArmCycle, "at_rest", property(lambda cycle: False))
    rig.event()
    assert rig.ticks[-1][0] == 1 + TREMBLE_CYCLES
    stepped = rig.harness.backend.data.time
    at = rig.message_id
    rig.wait(0.5)  # the client is away: the clock ticks, the world is left as it is
    assert rig.message_id - at == pytest.approx(400, abs=2)
    assert rig.harness.backend.data.time == stepped
    assert rig.states[-1][8:] == rig.states[-2][8:]
    rig.clock.client_event(disturbing=False)  # a Gripper connecting: its cycle, no settling
    rig.tick(False)
    assert rig.ticks[-1][0] == 1
    assert rig.harness.backend.data.time > stepped
    rig.event()  # a request (a SetLoad may lift the arm): the settling cycles again
    assert rig.ticks[-1][0] == 1 + TREMBLE_CYCLES
    rig.clock.world_changed()  # and a change through the control API
    rig.tick(False)
    assert rig.ticks[-1][0] == 1 + TREMBLE_CYCLES


def test_while_the_server_keeps_its_client_waiting_no_cycle_goes_without_its_answer():
    """The control API's HTTP server loads on its first connection (server/control_port.py):
    a lockstep client blocked in that request is not taken for one that stopped answering."""
    rig = Rig()
    assert rig.harness.move(0, 1) == MoveStatus.kMotionStarted
    rig.event()
    rig.on_socket.append(encode_command(message_id=rig.message_id, dq_c=[0.0] * 7))
    rig.tick(False)  # the first answer: the motion's cycles now await theirs
    waiting = rig.message_id
    rig.clock.server_busy = 1
    rig.wait(5 * LOCKSTEP_WINDOW)
    assert rig.message_id == waiting  # five windows passed, nothing released
    rig.clock.server_busy = 0
    rig.wait(LOCKSTEP_WINDOW)
    assert rig.message_id == waiting + 1  # then the window runs out as it always does
