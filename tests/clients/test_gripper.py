"""The Franka Hand through pylibfranka (and a raw socket where pylibfranka cannot look):
connect, homing, move timing, grasping the scene's cube and nothing, stop, bad input, no hand.

Durations are read on the gripper's own clock (GripperState.time, the robot's cycle counter),
never on the wall clock.
"""

from __future__ import annotations

import socket
import struct
import sys
from pathlib import Path

import pylibfranka
import pytest

from franka_sim.blocking_io import recv_exact
from franka_sim.protocol.codec import decode_gripper_state
from franka_sim.protocol.enums import GripperCommand
from franka_sim.protocol.gripper_messages import GRIPPER_STATE_SIZE, build_gripper_request
from franka_sim.testing import running_sim

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
import pick_and_place  # noqa: E402  (the IK and joint-motion helpers)


def seconds(state) -> float:
    return state.time.to_sec()


@pytest.fixture
def gripper(sim):
    return pylibfranka.Gripper(sim.host)


# -- connecting ----------------------------------------------------------------------------------
def test_connects_with_version_3_and_streams_its_state(gripper):
    assert gripper.server_version() == 3
    first, second = gripper.read_once(), gripper.read_once()
    assert first.width == pytest.approx(0.08, abs=1e-6)  # the fingers start open
    assert first.max_width == 0.08 and not first.is_grasped and first.temperature == 30
    # 10 Hz on the robot's clock: consecutive states are 100 ms apart, or a multiple when the
    # client drained some.
    gap = round((seconds(second) - seconds(first)) * 1000)
    assert gap > 0 and gap % 100 == 0


def test_no_gripper_refuses_port_1338_like_a_robot_without_a_hand():
    with running_sim("--no-gripper") as sim:
        with pytest.raises(pylibfranka.NetworkException, match="Connection to FCI refused"):
            pylibfranka.Gripper(sim.host)
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        assert sim.log_matching("no tool")


# -- actions -------------------------------------------------------------------------------------
def test_homing_measures_max_width(gripper):
    assert gripper.homing() is True
    state = gripper.read_once()
    assert state.max_width == pytest.approx(0.081, abs=2e-4)  # 0.080–0.082 on real hands
    assert state.width == pytest.approx(state.max_width, abs=1e-4)


def test_move_takes_width_over_speed_on_the_gripper_clock(gripper):
    before = gripper.read_once()
    assert gripper.move(0.02, 0.05) is True
    after = gripper.read_once()
    assert after.width == pytest.approx(0.02, abs=5e-4)
    duration = (before.width - 0.02) / 0.05  # 1.2 s
    elapsed = seconds(after) - seconds(before)
    # The move lies between the two states: at least its own duration; at most that plus the
    # 0.1 s state period on either side (and the client's own latency, generously bounded).
    assert elapsed >= duration - 1e-3
    assert elapsed < duration + 1.0


def test_grasp_closes_on_nothing_and_returns_false(gripper):
    assert gripper.grasp(0.05, 0.1, 20.0) is False
    state = gripper.read_once()
    assert state.width < 1e-3 and not state.is_grasped


def test_stop_when_idle_returns_true(gripper):
    assert gripper.stop() is True


def _grasp_and_lift(host: str):
    """The Hand brought down around the cube, grasping it, and lifted 15 cm: (the robot, the
    gripper, its state while it held the cube on the table)."""
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    gripper = pylibfranka.Gripper(host)
    above, at = pick_and_place.poses_over(pick_and_place.CUBE, pick_and_place.READY)
    pick_and_place.move_joints(robot, above)
    pick_and_place.move_joints(robot, at, max_speed=0.3)
    assert gripper.grasp(0.05, 0.1, 20.0) is True
    held = gripper.read_once()
    pick_and_place.move_joints(robot, above, max_speed=0.3)
    return robot, gripper, held


def test_grasps_the_cube_lifts_it_and_stop_lets_go(sim):
    robot, gripper, held = _grasp_and_lift(sim.host)
    assert held.is_grasped and held.width == pytest.approx(0.05, abs=1e-3)
    lifted = gripper.read_once()
    # Still between the fingers at the cube's width: the cube came up with the hand (had it
    # slipped out, the squeezing fingers would have closed on nothing).
    assert lifted.is_grasped and lifted.width == pytest.approx(held.width, abs=2e-4)
    assert gripper.stop() is True
    # The first GripperState after the reply shows the grasp released; on a loaded machine a
    # realtime read has once met a state from before it (a second read then showed it released).
    states = [gripper.read_once() for _ in range(2)]
    assert not states[-1].is_grasped


def test_in_lockstep_a_gripper_connecting_to_a_held_cube_costs_no_settling():
    """A grasped cube's contacts tremble for ever: lockstep gives such a world its settling
    cycles once, and a Gripper that connects later costs its own cycles only. (Each
    connection got 2000 more, no state sent meanwhile: on a busy machine a new Gripper's
    first read timed out, and each one moved the robot's clock on by seconds.)"""
    with running_sim("--clock", "lockstep") as sim:
        robot, gripper, _ = _grasp_and_lift(sim.host)
        del gripper
        times = []
        for _ in range(3):
            newcomer = pylibfranka.Gripper(sim.host)
            state = newcomer.read_once()
            assert state.is_grasped
            times.append(seconds(state))
            del newcomer
    assert all(0 < later - earlier <= 1.1 for earlier, later in zip(times, times[1:])), times


# -- bad input -----------------------------------------------------------------------------------
@pytest.mark.parametrize("call", [
    lambda g: g.move(-0.01, 0.1),
    lambda g: g.move(0.2, 0.1),
    lambda g: g.move(float("nan"), 0.1),
    lambda g: g.move(0.04, 0.0),
    lambda g: g.move(0.04, float("inf")),
    lambda g: g.grasp(0.04, 0.0, 20.0),
    lambda g: g.grasp(0.04, 0.1, -5.0),
    lambda g: g.grasp(0.2, 0.1, 20.0),
    lambda g: g.grasp(0.04, 0.1, 20.0, epsilon_inner=float("nan")),
], ids=["negative width", "over max_width", "NaN width", "zero speed", "infinite speed",
        "grasp zero speed", "negative force", "grasp over max_width", "NaN epsilon"])
def test_bad_arguments_fail_and_the_hand_keeps_working(sim, call):
    gripper = pylibfranka.Gripper(sim.host)
    with pytest.raises(pylibfranka.CommandException, match="Command failed"):
        call(gripper)
    assert gripper.move(0.07, 0.1) is True


# -- the wire, where pylibfranka cannot look ----------------------------------------------------
class RawGripperClient:
    """Gripper protocol v3 over plain sockets: requests, status replies, and every state."""

    def __init__(self, host: str, version: int = 3) -> None:
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind((host, 0))
        self.tcp = socket.create_connection((host, 1338), timeout=10, source_address=(host, 0))
        self.tcp.sendall(build_gripper_request(GripperCommand.Connect, 0, version=version,
                                               udp_port=self.udp.getsockname()[1]))
        self.connect_reply = struct.unpack("<HIIHH", self._recv(14))

    def _recv(self, n: int) -> bytes:
        return recv_exact(self.tcp, n)

    def send(self, command: GripperCommand, command_id: int, **fields) -> None:
        self.tcp.sendall(build_gripper_request(command, command_id, **fields))

    def reply(self) -> tuple[int, int, int]:
        command, command_id, _size, status = struct.unpack("<HIIH", self._recv(12))
        return command, command_id, status

    def states_until_reply(self) -> tuple[list[tuple[int, float]], tuple[int, int, int]]:
        """(message_id, width) of every state that arrives before the next reply, and the reply."""
        states = []
        self.tcp.setblocking(False)
        try:
            while True:
                try:
                    head = self.tcp.recv(12, socket.MSG_PEEK)
                except BlockingIOError:
                    head = b""
                if len(head) == 12:
                    break
                self.udp.settimeout(0.05)
                try:
                    data = self.udp.recv(64)
                except socket.timeout:
                    continue
                assert len(data) == GRIPPER_STATE_SIZE
                state = decode_gripper_state(data)
                states.append((int(state["message_id"]), float(state["width"])))
        finally:
            self.tcp.setblocking(True)
            self.tcp.settimeout(10)
        return states, self.reply()

    def close(self) -> None:
        self.tcp.close()
        self.udp.close()


def _closed_by_server(s: socket.socket) -> bool:
    s.settimeout(5)
    try:
        return s.recv(4096) == b""
    except ConnectionResetError:
        return True
    except socket.timeout:
        return False


def test_the_state_stream_shows_the_opening_moving_at_the_commanded_speed(sim):
    client = RawGripperClient(sim.host)
    client.send(GripperCommand.Move, 1, width=0.02, speed=0.04)  # 0.06 m: 1.5 s
    states, reply = client.states_until_reply()
    client.close()
    assert reply == (int(GripperCommand.Move), 1, 0)
    ids = [i for i, _ in states]
    assert all(b - a == 100 for a, b in zip(ids, ids[1:]))  # 10 Hz, none missing
    moving = [(i, w) for i, w in states if 0.021 < w < 0.079]
    assert len(moving) >= 12
    (i0, w0), (i1, w1) = moving[0], moving[-1]
    assert (w0 - w1) / ((i1 - i0) * 1e-3) == pytest.approx(0.04, rel=1e-3)


def test_a_move_in_progress_is_aborted_by_stop(sim):
    client = RawGripperClient(sim.host)
    client.send(GripperCommand.Move, 5, width=0.0, speed=0.02)  # 4 s
    client.send(GripperCommand.Stop, 6)
    assert client.reply() == (int(GripperCommand.Move), 5, 3)  # kAborted
    assert client.reply() == (int(GripperCommand.Stop), 6, 0)
    client.close()


def test_an_incompatible_client_is_told_our_version(sim):
    client = RawGripperClient(sim.host, version=2)
    assert client.connect_reply == (0, 0, 14, 1, 3)  # kIncompatibleLibraryVersion, version 3
    assert _closed_by_server(client.tcp)
    client.close()


@pytest.mark.parametrize("frame", [
    struct.pack("<HII", 77, 1, 10),  # unknown command
    struct.pack("<HII", 3, 1, 10),  # a Move with a Stop's size
    struct.pack("<HII", 1, 1, 3),  # size below the header
])
def test_malformed_frames_close_that_connection_and_the_hand_keeps_serving(sim, frame):
    client = RawGripperClient(sim.host)
    client.tcp.sendall(frame)
    assert _closed_by_server(client.tcp)
    client.close()
    assert sim.wait_for_log("closing gripper connection")
    assert len(sim.log_matching("closing gripper connection")) == 1
    assert pylibfranka.Gripper(sim.host).move(0.06, 0.1) is True


def test_one_gripper_client_at_a_time(sim):
    first = pylibfranka.Gripper(sim.host)
    second = socket.create_connection((sim.host, 1338), timeout=5)
    assert _closed_by_server(second)
    second.close()
    assert first.move(0.05, 0.1) is True
    assert sim.wait_for_log("refused gripper client")


def test_states_report_the_robot_clock(sim):
    robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
    gripper = pylibfranka.Gripper(sim.host)
    arm_ms = robot.read_once().time.to_sec() * 1000
    hand_ms = gripper.read_once().time.to_sec() * 1000
    # One clock: the hand's state read after the arm's is from a later (or the same) cycle, on
    # a 100 ms tick of the same counter.
    assert round(hand_ms) % 100 == 0
    assert hand_ms >= arm_ms
