"""Each resource of the control API through the Python client, against a served simulator."""

from __future__ import annotations

import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.config import READY_POSE
from franka_sim.control import Conflict, Control, NotFound
from franka_sim.operations.arm import MAX_PUSH_FORCE, MAX_PUSH_TORQUE
from support.clients import connect, pose

CUBE_START = [0.45, 0.0, 0.025]  # scenes/default.xml


def wait_cycles(control: Control, cycles: int, timeout: float = 30.0) -> None:
    """Until the simulator has run `cycles` more cycles (its clock, not the wall's)."""
    until = control.health()["cycle"] + cycles
    end = time.monotonic() + timeout
    while control.health()["cycle"] < until:
        assert time.monotonic() < end, "the simulator's clock does not advance"
        time.sleep(0.01)


def current_state(robot: pylibfranka.Robot, control: Control) -> pylibfranka.RobotState:
    """A state published after now: read_once may return one the client's socket has held for
    hundreds of cycles, and `cycle` is the last state that left, before what just changed."""
    cycle = control.health()["cycle"]
    state = robot.read_once()
    while round(state.time.to_sec() * 1000) <= cycle:  # libfranka's time: message_id ms
        state = robot.read_once()
    return state


def test_health_is_ready_and_says_what_the_robot_does(control, served):
    health = control.health()
    assert health == {"ready": True, "arm": "fr3", "robot": "fr3", "clock": "realtime",
                      "cycle": health["cycle"], "client_connected": False,
                      "tool_client_connected": False, "robot_mode": "Idle"}
    robot = connect(served.host)
    assert control.health()["client_connected"] is True
    gripper = pylibfranka.Gripper(served.host)
    assert control.health()["tool_client_connected"] is True
    del robot, gripper


def test_state_is_the_ground_truth_a_client_reads(control, served):
    robot = connect(served.host)
    seen = robot.read_once()
    state = control.state()  # at rest: the same as what the client saw
    for name in ("q", "dq", "tau_J"):  # (pylibfranka hands them over in single precision)
        np.testing.assert_allclose(state[name], getattr(seen, name), rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(state["O_T_EE"], pose(seen.O_T_EE), atol=1e-7)  # rows
    assert state["robot_mode"] == "Idle" and state["errors"] == []
    assert state["success_rate"] == 0.0 and state["gripper_width"] == pytest.approx(0.08)
    assert isinstance(state["cycle"], int) and state["cycle"] > 0
    del robot


def test_bodies_name_the_links_the_hand_and_the_scene(control):
    bodies = {body["name"]: body["free"] for body in control.bodies()}
    assert bodies["scene/cube"] is True and bodies["link7"] is False
    assert {"link0", "link1", "hand", "scene/table"} <= set(bodies)
    assert [name for name, free in bodies.items() if free] == ["scene/cube"]


def test_pose_of_a_link_under_the_names_descriptions_give_it(control):
    hand = control.pose("hand")
    assert control.pose("fr3_hand") == hand
    assert set(hand) == {"position", "quaternion", "linear_velocity", "angular_velocity", "free"}
    assert hand["free"] is False and hand["linear_velocity"] == [0.0, 0.0, 0.0]
    assert np.linalg.norm(hand["quaternion"]) == pytest.approx(1.0)
    flange = np.array(control.state()["O_T_EE"])[:3, 3]  # the TCP, 0.1034 m past the flange
    assert np.linalg.norm(np.array(hand["position"]) - flange) == pytest.approx(0.1034, abs=1e-3)
    with pytest.raises(NotFound, match="no body named 'link9'"):
        control.pose("link9")


def test_set_pose_moves_the_cube_and_pose_reads_it_back(control):
    placed = control.set_pose("cube", [0.5, 0.1, 0.2], quaternion=[0.0, 0.0, 0.0, 1.0])
    assert placed["position"] == [0.5, 0.1, 0.2] and placed["quaternion"] == [0.0, 0.0, 0.0, 1.0]
    assert placed["linear_velocity"] == [0.0, 0.0, 0.0]
    assert control.pose("scene/cube")["position"][2] <= 0.2
    wait_cycles(control, 600)  # it falls onto the table, with no client connected
    cube = control.pose("cube")
    assert cube["position"][2] == pytest.approx(0.025, abs=1e-3)
    np.testing.assert_allclose(cube["position"][:2], [0.5, 0.1], atol=1e-3)
    with pytest.raises(Conflict, match="not a free body"):
        control.set_pose("link4", [0.0, 0.0, 1.0])
    with pytest.raises(Conflict, match=r"inside another body: scene/cube into scene/table "
                                       r"\(15 mm deep\)"):
        control.set_pose("cube", [0.5, 0.1, 0.01])
    assert control.pose("cube")["position"] == cube["position"]  # as it was


def test_reset_puts_arm_cube_and_hand_back(control, served):
    robot = connect(served.host)
    control.set_pose("cube", [0.3, 0.3, 0.1])
    answer = control.reset(q=[0.1, -0.5, 0.0, -2.0, 0.0, 1.5, 0.5], gripper_width=0.04)
    assert answer["q"] == [0.1, -0.5, 0.0, -2.0, 0.0, 1.5, 0.5]
    assert answer["gripper_width"] == pytest.approx(0.04)
    state = current_state(robot, control)
    np.testing.assert_allclose(state.q, answer["q"], atol=1e-7)
    assert not any(state.dq)
    np.testing.assert_allclose(control.pose("cube")["position"], CUBE_START, atol=1e-4)
    gripper = pylibfranka.Gripper(served.host)
    assert gripper.read_once().width == pytest.approx(0.04, abs=1e-6)
    control.reset()
    np.testing.assert_allclose(current_state(robot, control).q, READY_POSE, atol=1e-7)
    assert gripper.read_once().width == pytest.approx(0.08, abs=1e-6)
    del robot, gripper


def test_a_push_reads_as_the_force_the_robot_exerts_and_ends_after_its_duration(control,
                                                                               served):
    robot = connect(served.host)
    model = robot.load_model()
    robot.set_collision_behavior([100.0] * 7, [100.0] * 7, [100.0] * 6, [100.0] * 6)
    answer = control.push("hand", force=[12.0, 0.0, 0.0], duration=0.5)
    assert answer == {"body": "hand", "force": [12.0, 0.0, 0.0], "torque": [0.0, 0.0, 0.0],
                      "cycles": 500}
    wait_cycles(control, 300)  # the arm yields to its new rest, the filter settles
    state = current_state(robot, control)
    O_F = np.array(state.O_F_ext_hat_K)
    assert O_F[0] == pytest.approx(-12.0, rel=0.01)  # the robot pushes back: −F
    np.testing.assert_allclose(O_F[1:3], 0.0, atol=0.1)
    J = np.reshape(model.zero_jacobian(state), (6, 7), order="F")  # at K = EE
    np.testing.assert_allclose(state.tau_ext_hat_filtered, J.T @ O_F, atol=0.02)
    assert np.abs(state.tau_ext_hat_filtered).max() > 1.0
    assert state.cartesian_contact[0] == 0.0  # 12 N is under the 100 N thresholds
    wait_cycles(control, 500)
    state = current_state(robot, control)
    assert not any(state.O_F_ext_hat_K) and not any(state.tau_ext_hat_filtered)
    del robot


def test_a_push_longer_than_the_idle_clock_runs_to_its_end_with_no_client(control):
    """With nobody connected the clock runs 2 s after a change: a longer push keeps it going
    to its end (a pause halfway would leave it on for the next client to feel)."""
    assert not control.health()["client_connected"]
    q = control.state()["q"]
    control.push("link7", force=[0.0, 0.0, -40.0], duration=2.5)
    wait_cycles(control, 3600)  # the push's 2500 cycles, then the hold takes the arm back
    assert control.state()["q"] == q


def test_the_strongest_push_taken_leaves_a_simulator_that_serves(control):
    for direction in ([0.0, 0.0, 1.0], [-0.6, 0.0, -0.8]):  # (~1 MN broke the step)
        control.reset()
        control.push("hand", force=[MAX_PUSH_FORCE * x for x in direction],
                     torque=[0.0, 0.0, MAX_PUSH_TORQUE], duration=0.5)
        wait_cycles(control, 1000)
        assert control.health()["ready"] and control.state()["robot_mode"] == "Idle"
    control.reset()


def test_a_push_during_a_motion_trips_the_collision_reflex_and_reset_clears_it(control,
                                                                              served):
    robot = connect(served.host)
    motion = robot.start_torque_control()
    motion.readOnce()
    control.push("link7", force=[0.0, 40.0, 0.0], duration=0.2)
    with pytest.raises(pylibfranka.ControlException, match="reflex"):
        for _ in range(2000):
            motion.readOnce()
            motion.writeOnce(pylibfranka.Torques([0.0] * 7))
    state = control.state()
    assert state["robot_mode"] == "Reflex"
    assert set(state["errors"]) & {"joint_reflex", "cartesian_reflex"}
    del motion
    control.reset()
    state = control.state()
    assert state["robot_mode"] == "Idle" and state["errors"] == []
    assert current_state(robot, control).robot_mode == pylibfranka.RobotMode.Idle
    motion = robot.start_torque_control()  # no recovery needed: a fresh robot
    for k in range(50):
        motion.readOnce()
        command = pylibfranka.Torques([0.0] * 7)
        command.motion_finished = k == 49
        motion.writeOnce(command)
    del motion, robot
