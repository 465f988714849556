"""Network faults, sans-IO: the spec's parser, each datagram's fate (a pure function of seed,
arm, direction and message_id) and one arm's link (what it holds, what goes now)."""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.protocol.codec import COMMAND_DTYPE
from franka_sim.faults import (COMMANDS, STATES, Burst, FaultPlan, FaultSpec,
                                      FaultSpecError, parse_spec, spec_from_fields)
from franka_sim.faults.link import ArmLink


def _command(message_id: int):
    record = np.zeros((), dtype=COMMAND_DTYPE)
    record["message_id"] = message_id
    return record


def _state(message_id: int) -> bytes:
    return message_id.to_bytes(8, "little") + b"state"


# -- the spec ------------------------------------------------------------------------------------
def test_a_spec_is_parsed_and_written_back():
    spec = parse_spec("loss=0.01, delay=2ms,jitter=500us,burst=20@5s,burst=3@1500ms,"
                      "reorder=0.1,dir=commands")
    assert spec == FaultSpec(loss=0.01, delay=2.0, jitter=0.5, reorder=0.1, dir="commands",
                             bursts=(Burst(1500, 3), Burst(5000, 20)))
    assert parse_spec(spec.text()) == spec
    assert spec_from_fields({"loss": 0.01, "delay": 2, "jitter": "0.5ms", "reorder": 0.1,
                             "burst": ["20@5s", "3@1.5s"], "dir": "commands"}) == spec
    assert spec_from_fields({"spec": spec.text()}) == spec


@pytest.mark.parametrize("text, reason", [
    ("", "empty spec"),
    ("loss", "expected KEY=VALUE"),
    ("los=0.1", "unknown fault 'los'"),
    ("loss=1.5", "a probability is in [0, 1]"),
    ("loss=nan", "a probability is in [0, 1]"),
    ("loss=0.1,loss=0.2", "loss given twice"),
    ("reorder=often", "not a number"),
    ("delay=fast", "not a duration"),
    ("delay=-1ms", "not a duration"),
    ("delay=2h", "not a duration"),
    ("delay=5s", "at most 1000 ms"),
    ("jitter=1s", "at most 100 ms"),
    ("burst=20", "expected N@T"),
    ("burst=x@5s", "expected N@T"),
    ("burst=0@5s", "1 to 60000 cycles"),
    ("burst=20@5.0005s", "a whole ms"),
    ("dir=up", "expected both, states, commands"),
])
def test_a_bad_spec_says_why_in_one_line(text, reason):
    with pytest.raises(FaultSpecError, match=None) as refused:
        parse_spec(text)
    assert reason in str(refused.value) and "\n" not in str(refused.value)


@pytest.mark.parametrize("fields, reason", [
    ({}, "no fault given"),
    ({"spec": "loss=0.1", "loss": 0.1}, "either spec or the fields"),
    ({"loss": True}, "must be a number or a string"),
    ({"loss": [0.1]}, "must be a number or a string"),
    ({"loss": "2"}, "a probability"),
])
def test_bad_fields_say_why(fields, reason):
    with pytest.raises(FaultSpecError) as refused:
        spec_from_fields(fields)
    assert reason in str(refused.value)


# -- the plan ------------------------------------------------------------------------------------
def test_the_same_seed_gives_the_same_fates_whatever_the_order_they_are_asked_in():
    spec = parse_spec("loss=0.1,jitter=1ms,reorder=0.1")
    ids = list(range(1000, 3000))
    a = [FaultPlan(spec, 7, 0).fate(d, n) for d in (STATES, COMMANDS) for n in ids]
    backwards = FaultPlan(spec, 7, 0)
    b = [backwards.fate(d, n) for d in (COMMANDS, STATES) for n in reversed(ids)]
    assert a == list(reversed(b))
    other_seed = [FaultPlan(spec, 8, 0).fate(d, n) for d in (STATES, COMMANDS) for n in ids]
    other_arm = [FaultPlan(spec, 7, 1).fate(d, n) for d in (STATES, COMMANDS) for n in ids]
    assert a != other_seed and a != other_arm


def test_loss_hits_each_direction_on_its_own_at_its_rate():
    plan = FaultPlan(parse_spec("loss=0.05"), 7, 0)
    lost = {d: {n for n in range(20_000) if plan.fate(d, n) is None} for d in (STATES, COMMANDS)}
    for d in (STATES, COMMANDS):
        assert len(lost[d]) == pytest.approx(1000, rel=0.15)
    assert len(lost[STATES] & lost[COMMANDS]) == pytest.approx(50, rel=0.5)  # independent


@pytest.mark.parametrize("direction, hit, spared", [
    ("commands", COMMANDS, STATES), ("states", STATES, COMMANDS)])
def test_dir_limits_every_fault_to_one_direction(direction, hit, spared):
    plan = FaultPlan(parse_spec(f"loss=0.5,delay=3ms,burst=10@1s,dir={direction}"), 7, 0)
    assert all(plan.fate(spared, n) == (0, False) for n in range(900, 1100))
    fates = [plan.fate(hit, n) for n in range(900, 1100)]
    assert None in fates and (3, False) in fates


def test_a_burst_loses_exactly_its_cycles_in_both_directions():
    plan = FaultPlan(parse_spec("burst=25@3s,burst=2@10ms"), 7, 0)
    for d in (STATES, COMMANDS):
        lost = [n for n in range(0, 5000) if plan.fate(d, n) is None]
        assert lost == [10, 11] + list(range(3000, 3025))


def test_a_plan_set_later_meets_the_same_fates_counted_from_its_origin():
    spec = parse_spec("loss=0.3,reorder=0.2,jitter=1ms,burst=5@20ms")
    fresh, later = FaultPlan(spec, 7, 0), FaultPlan(spec, 7, 0, origin=4321)
    for direction in (STATES, COMMANDS):
        assert ([later.fate(direction, 4321 + n) for n in range(200)]
                == [fresh.fate(direction, n) for n in range(200)])
    assert all(later.fate(STATES, 4321 + n) is None for n in range(20, 25))
    assert not all(later.fate(STATES, n) is None for n in range(20, 25))  # (not at 20 ms)


def test_delay_is_whole_cycles_rounded_up_and_jitter_a_truncated_normal():
    assert FaultPlan(parse_spec("delay=2ms"), 7, 0).fate(STATES, 5) == (2, False)
    assert FaultPlan(parse_spec("delay=0.2ms"), 7, 0).fate(STATES, 5) == (1, False)
    plan = FaultPlan(parse_spec("delay=2ms,jitter=0.5ms"), 7, 0)
    cycles = np.array([plan.fate(COMMANDS, n)[0] for n in range(10_000)])
    # latency ~ N(2, 0.5) ms: (1, 2] -> 2 cycles (50 %), (2, 3] -> 3 (48 %), the tails beyond
    assert set(np.unique(cycles)) <= {1, 2, 3, 4, 5}
    assert np.mean(cycles == 2) == pytest.approx(0.477, abs=0.03)
    assert np.mean(cycles == 3) == pytest.approx(0.477, abs=0.03)
    half = FaultPlan(parse_spec("jitter=1ms"), 7, 0)  # delay 0: half the datagrams go at once
    on_time = np.mean([half.fate(STATES, n) == (0, False) for n in range(10_000)])
    assert on_time == pytest.approx(0.5, abs=0.03)


def test_reorder_marks_its_share_of_datagrams():
    plan = FaultPlan(parse_spec("reorder=0.2"), 7, 0)
    reordered = sum(plan.fate(STATES, n) == (0, True) for n in range(10_000))
    assert reordered == pytest.approx(2000, rel=0.1)


# -- one arm's link ------------------------------------------------------------------------------
def _link(spec: str | None, seed: int = 7) -> ArmLink:
    link = ArmLink(0)
    link.new_client(("127.0.0.1", 5000))
    link.set_plan(None if spec is None else FaultPlan(parse_spec(spec), seed, 0))
    return link


def test_without_a_plan_everything_goes_at_once_and_the_client_owes_each_state():
    link = _link(None)
    assert link.states_out(10, _state(10)) == [_state(10)]
    assert link.fresh == 10 and not link.answered
    command = _command(10)
    assert link.command_in(command) == [command] and link.answered


def test_a_lost_state_is_not_waited_for_and_a_lost_answer_still_counts_as_answered():
    link = _link("burst=1@10ms")  # cycle 10 lost both ways
    assert link.states_out(9, _state(9)) == [_state(9)] and link.fresh == 9
    assert link.states_out(10, _state(10)) == []
    assert link.fresh is None  # nothing new reached the client: nothing to wait for
    assert link.command_in(_command(10)) == [] and link.counts["commands"]["dropped"] == 1
    link.states_out(11, _state(11))
    assert link.fresh == 11
    assert link.command_in(_command(11))
    assert link.answered


def test_a_delayed_state_leaves_with_a_later_cycle_and_newest_first():
    link = _link("delay=2ms,dir=states")
    assert link.states_out(10, _state(10)) == [] and link.fresh is None
    assert link.states_out(11, _state(11)) == []
    assert link.states_out(12, _state(12)) == [_state(10)] and link.fresh == 10
    link = _link("jitter=2ms,dir=states", seed=3)
    sent = [link.states_out(n, _state(n)) for n in range(100, 400)]
    for batch in sent:  # a cycle's datagrams leave newest first
        ids = [int.from_bytes(d[:8], "little") for d in batch]
        assert ids == sorted(ids, reverse=True)
    assert sum(map(len, sent)) + link.held[0] == 300


def test_a_delayed_command_reaches_the_robot_at_its_cycle():
    link = _link("delay=2ms,dir=commands")
    link.states_out(10, _state(10))
    command = _command(10)
    assert link.command_in(command) == [] and link.answered  # the client did answer
    assert link.commands_due() == []
    link.states_out(11, _state(11))
    assert link.commands_due() == []
    link.states_out(12, _state(12))
    assert link.commands_due() == [command]  # at cycle 10 + 2: late, the robot drops it
    assert link.held == (0, 0)


def test_a_reordered_command_follows_the_next_one_or_goes_two_cycles_on():
    spec = "reorder=1,dir=commands"
    link = _link(spec)
    link.states_out(10, _state(10))
    first, second = _command(10), _command(11)
    assert link.command_in(first) == []
    link.states_out(11, _state(11))
    link.set_plan(None)
    assert link.command_in(second) == [second, first]  # swapped
    link = _link(spec)
    link.states_out(10, _state(10))
    assert link.command_in(first) == []
    link.states_out(11, _state(11))
    assert link.commands_due() == []
    link.states_out(12, _state(12))
    assert link.commands_due() == [first]  # nothing came after it


def test_a_reordered_state_goes_after_the_next_one():
    link = _link("reorder=1,dir=states")
    assert link.states_out(10, _state(10)) == []
    counts = dict(link.counts["states"])
    link.set_plan(None)
    assert link.states_out(11, _state(11)) == [_state(11), _state(10)]
    assert link.fresh == 11
    # Counted as a reordered command is: reordered, not delayed.
    assert counts == {"seen": 1, "dropped": 0, "delayed": 0, "reordered": 1}


def test_a_new_client_finds_nothing_held_for_the_last():
    link = _link("delay=5ms")
    link.states_out(10, _state(10))
    link.command_in(_command(10))
    assert link.held == (1, 1)
    link.new_client(("127.0.0.1", 5001))
    assert link.held == (0, 0) and link.fresh is None


# -- a lockstep motion's hold --------------------------------------------------------------------
def test_each_held_state_of_a_motion_start_meets_a_fate_of_its_own():
    """The world held for a client's first command sends its state again under new ids, all
    keyed as the motion's first state (their number is the client's timing): each takes its
    place in the hold too, so one fate does not befall every answer until the first command
    gets through, and the cycles after it keep the keys they had."""
    from franka_sim.server.network_faults import NetworkFaults

    faults = NetworkFaults(seed=7)
    faults.repeated(), faults.repeated()  # a client lingered before the motion
    faults.motion_started(100)
    for message_id in (101, 102, 103):
        faults.held(message_id)
    assert [faults.key(n) for n in (100, 101, 102, 103, 104)] == \
        [(95, 0), (98, 1), (98, 2), (98, 3), (99, 0)]
    plan = FaultPlan(parse_spec("jitter=0.5ms,dir=commands"), 2, 0)
    held = [plan.fate(COMMANDS, 98, j) for j in range(1, 41)]
    assert len(set(held)) > 1 and (0, False) in held  # some answer goes through
    assert plan.fate(COMMANDS, 98) == plan.fate(COMMANDS, 98, 0)  # the usual key unchanged
    # A burst reaches a held state as it reaches the cycle that many after the first state.
    burst = FaultPlan(parse_spec("burst=3@100ms"), 7, 0)
    assert [burst.fate(STATES, 98, j) is None for j in range(5)] == \
        [False, False, True, True, True]
