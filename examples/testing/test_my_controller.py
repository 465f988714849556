"""my_controller against a simulated FR3 + Franka Hand: the `franka_sim` fixture, no conftest.

python -m pytest examples/testing -n 2
"""

import numpy as np
import pylibfranka
import pytest

from my_controller import connect, move_to

# The simulator's start pose (libfranka's "ready" pose), where every test begins.
START = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4])
TARGET = START + [0.3, 0.2, 0.0, 0.3, 0.0, -0.2, 0.0]
# Taught poses for the default scene's cube (5 cm, centred at (0.45, 0, 0.025)), Hand pointing
# down: the grasp point 1.5 cm above the cube's centre, and 15 cm above that.
AT_CUBE = [0.0, 0.3503, 0.0, -2.5381, 0.0, 2.8884, 0.7854]
ABOVE_CUBE = [0.0, -0.0649, 0.0, -2.5482, 0.0, 2.4833, 0.7854]


def test_reaches_the_target(franka_sim):
    robot = connect(franka_sim.host)
    state = move_to(robot, TARGET)
    assert np.allclose(state.q, TARGET, atol=0.01)
    truth = franka_sim.control.state()  # the simulator's own account, not the client's
    assert truth["robot_mode"] == "Idle" and truth["errors"] == []
    assert np.allclose(truth["q"], TARGET, atol=0.01)


def test_holds_under_a_push(franka_sim):
    robot = connect(franka_sim.host)
    pushed, worst = [], 0.0

    def push_then_watch(t, state):  # runs inside the control loop, once per cycle
        nonlocal worst
        if t >= 0.6 and not pushed:  # the set-point has been on TARGET for 0.1 s
            franka_sim.control.push("link7", force=[15, 0, 0], duration=0.2)
            pushed.append(t)
        if pushed:
            worst = max(worst, float(np.abs(np.array(state.q) - TARGET).max()))

    state = move_to(robot, TARGET, duration=0.5, hold=0.9, every_cycle=push_then_watch)
    assert worst > 0.005  # the push moved the arm (15 N on the wrist: ~0.02 rad)...
    assert np.allclose(state.q, TARGET, atol=0.005)  # ...and it came back
    assert franka_sim.control.state()["robot_mode"] == "Idle"


@pytest.mark.franka_sim(enforce_motion_limits=True)
def test_a_too_fast_command_aborts(franka_sim):
    robot = connect(franka_sim.host)
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    q = np.array(control.readOnce()[0].q_d)
    with pytest.raises(pylibfranka.ControlException, match="velocity_discontinuity"):
        for cycle in range(100):
            control.readOnce()
            if cycle == 5:  # the first commands stay at the start pose, as they must
                q[3] += 0.05  # then a 0.05 rad step in one 1 ms cycle: 50 rad/s
            control.writeOnce(pylibfranka.JointPositions(q.tolist()))
    errors = franka_sim.control.state()["errors"]
    assert "joint_motion_generator_velocity_discontinuity" in errors
    assert any("velocity_discontinuity" in line for line in franka_sim.log)


def test_picks_the_cube(franka_sim):
    robot = connect(franka_sim.host)
    gripper = pylibfranka.Gripper(franka_sim.host)
    model = robot.load_model()
    move_to(robot, ABOVE_CUBE, model=model)
    move_to(robot, AT_CUBE, model=model)
    assert gripper.grasp(0.05, 0.1, 20.0)  # width, speed, force: holds a 5 cm object
    move_to(robot, ABOVE_CUBE, model=model)
    assert gripper.read_once().is_grasped
    assert franka_sim.control.pose("cube")["position"][2] > 0.1
