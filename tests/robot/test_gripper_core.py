"""The Franka Hand's behaviour, cycle by cycle, without sockets: the gripper state machine driving
the simulated fingers (MuJoCo, default scene), as the server wires them.

Time here is the robot's cycle counter, so durations are exact and no wall clock is involved.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.protocol.codec import decode_gripper_state
from franka_sim.protocol.enums import GRIPPER_VERSION, GripperCommand, GripperStatus
from franka_sim.protocol.framing import Frame, decode_request
from franka_sim.protocol.gripper_messages import GRIPPER_REQUEST_STRUCTS, build_gripper_request
from franka_sim.robot.hand import MAX_SPEED, NOMINAL_MAX_WIDTH, STATE_PERIOD
from franka_sim.robot.hand import Hand as HandDevice
from franka_sim.robot.session import GRIPPER, tool_session
from franka_sim.robot.session import SessionError

DESC = load_arm_description(default_urdf_text())
K = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
D = np.array([60, 60, 50, 50, 30, 25, 15.0])
Move, Grasp, Homing, Stop = (GripperCommand.Move, GripperCommand.Grasp, GripperCommand.Homing,
                             GripperCommand.Stop)


def status_of(reply: bytes) -> tuple[GripperCommand, int, GripperStatus]:
    command, command_id, _size, status = struct.unpack("<HIIH", reply)
    return GripperCommand(command), command_id, GripperStatus(status)


def decoded(command: GripperCommand, command_id: int = 1, **fields):
    data = build_gripper_request(command, command_id, **fields)
    return decode_request(Frame(int(command), command_id, data), GRIPPER_REQUEST_STRUCTS)


class Hand:
    """The server's per-cycle gripper wiring: step with the Hand's command, then advance it."""

    def __init__(self, q=READY_POSE, **gripper_kwargs) -> None:
        self.backend = MujocoBackend(DESC, np.array(q), scene_xml=default_scene_path(),
                                     tool=FINGERS)
        self.hold = JointCommand.impedance(np.array(q), K, D)
        self.gripper = HandDevice(**gripper_kwargs)
        self.cycle = 0
        self.replies: list[tuple[int, tuple]] = []  # (cycle, (command, id, status))
        self.run(1)

    def run(self, cycles: int) -> None:
        for _ in range(cycles):
            self.cycle += 1
            measured = self.backend.step(self.hold, self.gripper.command)
            self.gripper.advance(self.cycle, measured.tool)
            self.replies += [(self.cycle, status_of(r)) for r in self.gripper.take_replies()]

    def request(self, command: GripperCommand, command_id: int = 1, **fields) -> list[tuple]:
        return [status_of(r) for r in
                self.gripper.request(command, command_id, decoded(command, command_id, **fields))]

    def until_answered(self, limit: int = 5000) -> tuple[int, tuple]:
        """Run until an action is answered; (cycles it took, (command, id, status))."""
        start, seen = self.cycle, len(self.replies)
        while len(self.replies) == seen:
            assert self.cycle - start < limit, "no answer"
            self.run(1)
        cycle, reply = self.replies[-1]
        return cycle - start, reply

    @property
    def width(self) -> float:
        return self.backend.measure().tool.width


@pytest.fixture(scope="module")
def homed():
    hand = Hand()
    hand.request(Homing)
    hand.until_answered()
    return hand


def test_homing_closes_opens_and_measures_max_width():
    hand = Hand()
    assert hand.gripper.max_width == NOMINAL_MAX_WIDTH  # before any homing: the datasheet's
    assert hand.request(Homing, 7) == []
    cycles, reply = hand.until_answered()
    assert reply == (Homing, 7, GripperStatus.kSuccess)
    # Real hands measure 0.080–0.082 m at the stops; ours are at 2 × 0.0405 m.
    assert hand.gripper.max_width == pytest.approx(0.081, abs=2e-4)
    assert hand.width == pytest.approx(hand.gripper.max_width, abs=1e-5)
    # Close from 0.08 and reopen to 0.081 at 0.1 m/s: ~1.6 s of the robot's clock.
    assert 1600 <= cycles <= 1700


@pytest.mark.parametrize("goal, speed", [(0.02, 0.05), (0.07, 0.1), (0.05, 0.02)])
def test_move_takes_the_time_its_speed_implies(homed, goal, speed):
    start = homed.width
    assert homed.request(Move, 3, width=goal, speed=speed) == []
    cycles, reply = homed.until_answered()
    assert reply == (Move, 3, GripperStatus.kSuccess)
    assert cycles == math.ceil(abs(goal - start) / speed / 1e-3 - 1e-9)  # to the cycle
    assert homed.width == pytest.approx(goal, abs=5e-4)
    homed.run(200)  # and it stays there
    assert homed.width == pytest.approx(goal, abs=1e-4)


def test_speed_above_the_hands_maximum_is_clamped(homed):
    homed.request(Move, width=0.03, speed=1.0)
    homed.until_answered()
    start = homed.width
    homed.request(Move, width=0.08, speed=5.0)
    cycles, reply = homed.until_answered()
    assert reply[2] is GripperStatus.kSuccess
    assert cycles == math.ceil((0.08 - start) / MAX_SPEED / 1e-3 - 1e-9)


def test_grasp_on_nothing_is_unsuccessful_and_stops_squeezing(homed):
    homed.request(Move, width=0.06, speed=0.1)
    homed.until_answered()
    homed.request(Grasp, 4, width=0.03, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1,
                  force=30.0)
    cycles, reply = homed.until_answered()
    assert reply == (Grasp, 4, GripperStatus.kUnsuccessful)
    assert homed.width < 1e-4 and not homed.gripper.is_grasped
    assert cycles < 700  # 0.6 s of closing, then 50 ms of squeezing before the verdict
    homed.run(50)
    assert abs(homed.backend.measure().tool.force) < 1.0  # it let go


def test_grasp_width_rule_is_libfranka_s(homed):
    """Closing on nothing ends at d ≈ 0, which a grasp for width 0 accepts."""
    homed.request(Move, width=0.02, speed=0.1)
    homed.until_answered()
    homed.request(Grasp, width=0.0, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1,
                  force=10.0)
    assert homed.until_answered()[1][2] is GripperStatus.kSuccess
    assert homed.gripper.is_grasped
    homed.request(Stop)
    assert not homed.gripper.is_grasped


@pytest.mark.parametrize("fields, why", [
    (dict(width=-0.01, speed=0.1), "negative width"),
    (dict(width=0.09, speed=0.1), "beyond max_width"),
    (dict(width=float("nan"), speed=0.1), "NaN width"),
    (dict(width=0.04, speed=0.0), "zero speed"),
    (dict(width=0.04, speed=-0.1), "negative speed"),
    (dict(width=0.04, speed=1e-6), "a crawl that would block the client for hours"),
    (dict(width=0.04, speed=float("inf")), "infinite speed"),
])
def test_bad_move_arguments_fail_at_once(fields, why):
    hand = Hand()
    assert hand.request(Move, 9, **fields) == [(Move, 9, GripperStatus.kFail)], why
    assert hand.gripper.command is None  # nothing moves


@pytest.mark.parametrize("fields, why", [
    (dict(width=0.05, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1, force=0.0), "force 0"),
    (dict(width=0.05, epsilon_inner=-0.1, epsilon_outer=0.005, speed=0.1, force=20), "ε < 0"),
    (dict(width=0.05, epsilon_inner=0.005, epsilon_outer=float("nan"), speed=0.1, force=20),
     "NaN ε"),
    (dict(width=0.05, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.0, force=20), "speed 0"),
    (dict(width=-0.05, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1, force=20), "width<0"),
    (dict(width=0.05, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1,
          force=float("inf")), "infinite force"),
])
def test_bad_grasp_arguments_fail_at_once(fields, why):
    hand = Hand()
    assert hand.request(Grasp, 9, **fields) == [(Grasp, 9, GripperStatus.kFail)], why


def test_stop_aborts_a_running_move_and_holds_where_the_fingers_are():
    hand = Hand()
    hand.request(Move, 5, width=0.0, speed=0.05)
    hand.run(400)
    replies = hand.request(Stop, 6)
    assert replies == [(Move, 5, GripperStatus.kAborted), (Stop, 6, GripperStatus.kSuccess)]
    where = hand.width
    assert 0.055 < where < 0.065
    hand.run(300)
    assert hand.width == pytest.approx(where, abs=2e-4) and hand.replies == []


def test_a_new_action_preempts_the_running_one():
    hand = Hand()
    hand.request(Move, 1, width=0.0, speed=0.05)
    hand.run(100)
    assert hand.request(Move, 2, width=0.08, speed=0.05) == [(Move, 1, GripperStatus.kAborted)]
    assert hand.until_answered()[1] == (Move, 2, GripperStatus.kSuccess)


def test_stop_when_idle_succeeds():
    assert Hand().request(Stop, 3) == [(Stop, 3, GripperStatus.kSuccess)]


def test_a_blocked_move_answers_unsuccessful():
    """Closing the fingers on the cube with a Move: they stop on it and the Move gives up."""
    import pick_and_place

    _, at = pick_and_place.poses_over(pick_and_place.CUBE, pick_and_place.READY)
    hand = Hand(q=at)
    hand.request(Move, 2, width=0.01, speed=0.1)
    cycles, reply = hand.until_answered()
    assert reply == (Move, 2, GripperStatus.kUnsuccessful)
    assert hand.width == pytest.approx(0.05, abs=1e-3)  # stopped by the 5 cm cube
    assert cycles == pytest.approx(700 + 500, abs=2)  # its ramp, then 0.5 s of trying


def test_grasping_the_cube_squeezes_with_the_commanded_force():
    import pick_and_place

    _, at = pick_and_place.poses_over(pick_and_place.CUBE, pick_and_place.READY)
    hand = Hand(q=at)
    hand.request(Grasp, 8, width=0.05, epsilon_inner=0.005, epsilon_outer=0.005, speed=0.1,
                 force=35.0)
    assert hand.until_answered()[1] == (Grasp, 8, GripperStatus.kSuccess)
    hand.run(100)
    fingers = hand.backend.measure().tool
    assert fingers.width == pytest.approx(0.05, abs=1e-4)  # stiff pads: microns of squeeze
    assert fingers.force == pytest.approx(35.0, rel=1e-6)
    assert hand.gripper.is_grasped
    hand.request(Stop)
    hand.run(100)
    assert abs(hand.backend.measure().tool.force) < 1.0 and not hand.gripper.is_grasped


def test_state_every_100_cycles_on_the_robot_clock(homed):
    assert STATE_PERIOD == 100  # 10 Hz, the real hand's rate
    assert [c for c in range(1, 1001) if homed.gripper.state_due(c)] == list(range(100, 1001, 100))
    state = decode_gripper_state(homed.gripper.pack_state(homed.cycle))
    assert int(state["message_id"]) == homed.cycle
    assert state["width"] == pytest.approx(homed.width, abs=1e-9)  # (to the nanometre)
    assert state["max_width"] == homed.gripper.max_width
    assert int(state["temperature"]) == 30


def test_a_departed_client_leaves_no_answers_behind():
    hand = Hand()
    hand.request(Move, 1, width=0.02, speed=0.05)
    hand.run(10)
    hand.gripper.client_gone()
    hand.run(2000)
    assert hand.replies == []
    assert hand.gripper.command is not None  # holding where the fingers stopped


# -- the session: handshake and framing ------------------------------------------------------------
def connect_bytes(version=GRIPPER_VERSION, udp_port=4242) -> bytes:
    return build_gripper_request(GripperCommand.Connect, 0, version=version, udp_port=udp_port)


def test_connect_checks_the_version():
    session = tool_session(GRIPPER, HandDevice())
    (reply,) = session.feed(connect_bytes())
    assert struct.unpack("<HIIHH", reply) == (0, 0, 14, 0, 3)
    assert session.handshake.udp_port == 4242 and not session.closed
    old = tool_session(GRIPPER, HandDevice())
    (reply,) = old.feed(connect_bytes(version=2))
    assert struct.unpack("<HIIHH", reply) == (0, 0, 14, 1, 3)  # kIncompatibleLibraryVersion, v3
    assert old.closed and old.handshake is None


@pytest.mark.parametrize("data, why", [
    (struct.pack("<HII", 9, 1, 10), "unknown command"),
    (struct.pack("<HII", 3, 1, 10), "Move with the size of a Stop"),
    (struct.pack("<HII", 1, 1, 4), "size below the header"),
    (struct.pack("<HII", 1, 1, 1 << 30), "absurd size"),
])
def test_malformed_frames_end_the_session(data, why):
    session = tool_session(GRIPPER, HandDevice())
    session.feed(connect_bytes())
    with pytest.raises(SessionError):
        session.feed(data)
    assert session.closed, why


def test_commands_before_connect_end_the_session():
    with pytest.raises(SessionError):
        tool_session(GRIPPER, HandDevice()).feed(build_gripper_request(Homing, 1))


def test_split_and_batched_requests_are_all_answered():
    session = tool_session(GRIPPER, HandDevice())
    data = connect_bytes() + build_gripper_request(Stop, 1) + build_gripper_request(Stop, 2)
    replies = [r for i in range(len(data)) for r in session.feed(data[i:i + 1])]
    assert [struct.unpack_from("<HI", r) for r in replies] == [(0, 0), (4, 1), (4, 2)]


def test_a_reset_hand_is_unhomed_all_through_no_wider_than_its_max_width():
    """Homed, then reset (POST /reset): max_width is the datasheet's again, and so is the
    widest the Hand holds its fingers. A homing stopped at the stops then holds them at
    max_width, not at the earlier homing's, and a Move to the width it reports succeeds."""
    hand = Hand()
    hand.request(Homing, 1)
    hand.until_answered()
    hand.gripper.reset(hand.backend.measure().tool)
    assert hand.gripper.max_width == NOMINAL_MAX_WIDTH
    hand.request(Homing, 2)
    hand.run(1640)  # closed, and opened again to the stops: measuring there
    hand.request(Stop, 3)
    hand.run(300)
    width = float(decode_gripper_state(hand.gripper.pack_state(hand.cycle))["width"])
    assert width <= hand.gripper.max_width
    hand.request(Move, 4, width=width, speed=0.1)
    assert hand.until_answered()[1] == (Move, 4, GripperStatus.kSuccess)


def test_the_hands_width_is_reported_to_the_nanometre():
    """Squeezing nothing, the fingers settle onto each other: the width reads a few nm at
    most, to the nanometre, not the 1e-49 m of dust a physics settling onto its contact
    leaves (nor 6e-17 m past max_width when held open)."""
    hand = Hand()
    hand.request(Grasp, 9, width=0.0, epsilon_inner=0.0, epsilon_outer=0.0, speed=0.1, force=40)
    hand.until_answered()
    hand.run(300)
    width = float(decode_gripper_state(hand.gripper.pack_state(hand.cycle))["width"])
    assert 0.0 <= width < 1e-6 and width == round(width, 9)
