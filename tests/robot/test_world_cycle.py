"""A world cycle of two arms, sans-IO: one physics step for both, states that share a clock, a
lockstep answer that waits for every streaming arm, and the same bits from the same streams."""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.assembly import WorldParts
from franka_sim.config import ArmSpec, Config
from franka_sim.protocol.codec import decode_command, decode_state, encode_command
from franka_sim.robot.world_cycle import WorldCycle
from support.harness import move_request

SPECS = (ArmSpec("left", "127.0.0.2"), ArmSpec("right", "127.0.0.3"))


def world() -> tuple[WorldCycle, WorldParts]:
    parts = WorldParts(Config(arms=SPECS, scene="dual_arm_table"))
    cycle = parts.make_cycle(parts.make_physics(), [lambda: False] * 2)
    return cycle, parts


def step(cycle: WorldCycle) -> list:
    released = cycle.release()
    cycle.complete(released)
    return [decode_state(state) for state in released.states]


def answer(arm: int, state, **fields) -> tuple[int, object]:
    return arm, decode_command(encode_command(message_id=int(state["message_id"]), **fields))


def run(streams: dict[int, float], cycles: int = 400) -> list[bytes]:
    """Joint-position motions of joint 1 on the given arms (arm → amplitude), every state's
    bytes."""
    cycle, parts = world()
    states = step(cycle)
    for arm in streams:
        parts.arms[arm].core.request_move(5, move_request(0, 0))  # joint position generator
    out = []
    q0 = np.array(parts.config.q0)
    for k in range(cycles):
        released = cycle.release()
        cycle.complete(released)
        out.append(b"".join(released.states))
        states = [decode_state(state) for state in released.states]
        for arm, amplitude in streams.items():
            q = q0.copy()
            q[0] += amplitude * 0.5 * (1 - np.cos(np.pi * k / cycles))
            cycle.receive(*answer(arm, states[arm], q_c=q))
    return out


def test_both_arms_publish_the_same_cycle():
    cycle, _ = world()
    for _ in range(3):
        left, right = step(cycle)
        assert left["message_id"] == right["message_id"]


def test_one_arm_moving_leaves_the_other_exactly_where_it_was():
    cycle, parts = world()
    before = step(cycle)[1]
    parts.arms[0].core.request_move(5, move_request(0, 1))  # joint velocity, left only
    for k in range(300):
        left, right = step(cycle)
        dq = np.zeros(7)
        dq[0] = 0.2 * np.sin(np.pi * k / 300)
        cycle.receive(*answer(0, left, dq_c=dq))
    assert abs(left["q"][0] - before["q"][0]) > 0.01
    assert right["q"].tobytes() == before["q"].tobytes()


def test_the_answer_releases_the_next_cycle_once_every_streaming_arm_gave_it():
    cycle, parts = world()
    step(cycle)
    for arm in parts.arms:
        arm.core.request_move(5, move_request(0, 1))
    states = step(cycle)  # the motions' first states: libfranka answers neither
    states = step(cycle)
    assert cycle.lockstep_applies and not cycle.first_motion_state
    assert not cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))  # the right one is owed
    assert cycle.receive(*answer(1, states[1], dq_c=np.zeros(7)))  # now both: go


def test_beside_a_stream_a_motion_is_waited_for_from_its_second_state():
    """Its first state is not waited for (libfranka never answers it); from the next on it is,
    before its client's first command too: beside another arm's stream that client would
    otherwise fall behind by however slow it is to start (and be braked after 20 cycles)."""
    cycle, parts = world()
    step(cycle)
    parts.arms[0].core.request_move(5, move_request(0, 1))
    step(cycle)
    states = step(cycle)  # left streams from here
    parts.arms[1].core.request_move(5, move_request(0, 1))
    cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    states = step(cycle)  # right's first motion state
    assert not cycle.first_motion_state  # the streaming left arm sets the pace
    assert cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    states = step(cycle)  # right's second: its client answers this one (or the next)
    assert cycle.waits_for == {0, 1}
    assert not cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    assert cycle.receive(*answer(1, states[1], dq_c=np.zeros(7)))


def _right_silent():
    """Both arms in a velocity motion; the right client says nothing until it counts as
    silent: (the cycle, its parts, the last states, the cycles that took)."""
    cycle, parts = world()
    step(cycle)
    for arm in parts.arms:
        arm.core.request_move(5, move_request(0, 1))
    step(cycle)
    states = step(cycle)
    waited = 0
    while not parts.arms[1].core.client_silent:
        assert not cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))  # (right is owed)
        states = step(cycle)
        waited += 1
    return cycle, parts, states, waited


def test_a_silent_client_is_not_waited_for_beside_a_streaming_one():
    """One arm's client paused (a debugger) for 20 cycles: its arm is braked and held, and the
    other arm's answers alone release the cycles (a window each for the silent one would hold
    the world to ten cycles a second); heard again, it is waited for again. Alone, a silent
    client is still waited for."""
    cycle, parts, states, waited = _right_silent()
    assert waited >= 18  # (20 cycles lost in a row make a client silent)
    assert cycle.waits_for == {0}
    assert cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    states = step(cycle)
    assert not cycle.receive(*answer(1, states[1], dq_c=np.zeros(7)))  # heard again
    assert cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    states = step(cycle)
    assert cycle.waits_for == {0, 1}


def test_a_silent_client_heard_only_late_is_waited_for_again():
    """Not waited for, a resumed client answers each state after the other arm's answer has
    released the next cycle: late every time. Heard late, it is waited for again, so its next
    answer is on time and its motion goes on (it stayed braked to the motion's end)."""
    cycle, parts, states, _ = _right_silent()
    assert cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    read, states = states, step(cycle)
    assert not cycle.receive(*answer(1, read[1], dq_c=np.zeros(7)))  # its answer, late
    assert cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    states = step(cycle)
    assert cycle.waits_for == {0, 1}
    assert not cycle.receive(*answer(0, states[0], dq_c=np.zeros(7)))
    assert cycle.receive(*answer(1, states[1], dq_c=np.zeros(7)))  # on time: heard
    step(cycle)
    assert not parts.arms[1].core.client_silent


def test_skipped_ids_count_as_completed():
    """Where an event lands (a recording's `position`) reads the same after a skip as replay
    puts it: between completed cycles."""
    cycle, parts = world()
    step(cycle)
    cycle.skip(998)
    assert all(part.completed_id == cycle.message_id for part in cycle.parts)


@pytest.mark.parametrize("streams", [{0: 0.3, 1: -0.3}, {1: 0.2}])
def test_the_same_command_streams_give_the_same_bits(streams):
    first, second = run(streams), run(streams)
    assert first == second
    assert first[-1] != first[0]  # the arms did move


def test_a_world_no_state_of_which_can_be_published_fails_after_a_second(monkeypatch):
    """One cycle whose state cannot be packed costs that state; a second of them in a row
    ends the cycle (the server then answers 503 and exits non-zero) rather than serving a
    stream that never comes."""
    from franka_sim.robot.arm_core import ArmCore
    from franka_sim.robot.arm_cycle import GIVE_UP_AFTER

    parts = WorldParts(Config())
    cycle = parts.make_cycle(parts.make_physics(), [lambda: False])
    assert step(cycle)[0] is not None

    def broken(*_):
        raise FloatingPointError("no state")

    monkeypatch.setattr(ArmCore, "publish", broken)
    for _ in range(GIVE_UP_AFTER - 1):
        released = cycle.release()
        cycle.complete(released)
        assert released.states == (None,)
    with pytest.raises(FloatingPointError):
        cycle.release()
    monkeypatch.undo()  # one good cycle in between starts the count again
    assert step(cycle)[0] is not None
