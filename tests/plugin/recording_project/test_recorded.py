"""A user's test module whose runs the plugin records. Run by tests/plugin/test_recording.py in
a throw-away directory: the first test leaves the world changed every way a client can, the
second starts from the reset world at a later message_id and fails."""

import numpy as np
import pylibfranka

JI = pylibfranka.ControllerMode.JointImpedance


def _move(robot, dq):
    control = robot.start_joint_position_control(JI)
    q0 = np.array(control.readOnce()[0].q_d)
    for k in range(1, 301):
        control.readOnce()
        q = q0 + dq * 0.5 * (1 - np.cos(np.pi * k / 300))
        command = pylibfranka.JointPositions(q.tolist())
        command.motion_finished = k == 300
        control.writeOnce(command)
    del control


def test_changes_the_world_and_passes(franka_sim):
    robot = pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore)
    robot.set_collision_behavior([30.0] * 7, [30.0] * 7, [30.0] * 6, [30.0] * 6)
    robot.set_load(0.5, [0.0, 0.0, 0.05], [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3])
    _move(robot, np.array([0.2, 0.1, 0, -0.2, 0, 0.2, 0.1]))
    gripper = pylibfranka.Gripper(franka_sim.host)
    assert gripper.move(0.02, 0.1)
    franka_sim.control.set_pose("cube", [0.5, -0.1, 0.3])


def test_moves_then_fails(franka_sim):
    robot = pylibfranka.Robot(franka_sim.host, pylibfranka.RealtimeConfig.kIgnore)
    _move(robot, np.array([0, 0.1, 0, -0.1, 0, 0, 0]))
    gripper = pylibfranka.Gripper(franka_sim.host)
    assert gripper.move(0.06, 0.1)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Move, "deliberately failing"
