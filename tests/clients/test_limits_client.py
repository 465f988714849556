"""The safety layer through pylibfranka: each error a real client can provoke is named as the
robot names it, aborts the motion (with --enforce-motion-limits), and recovers."""

from __future__ import annotations

import math

import numpy as np
import pylibfranka
import pytest

from franka_sim.testing import running_sim
from support.clients import connect, pose

JI = pylibfranka.ControllerMode.JointImpedance


@pytest.fixture(scope="module")
def enforcing():
    with running_sim("--enforce-motion-limits", "--clock", "lockstep") as sim:
        yield sim


@pytest.fixture(scope="module")
def shared_robot(enforcing):
    # One client for the module: the robot admits one at a time, and a Robot object kept alive
    # by an exception's traceback would hold the connection into the next test.
    return connect(enforcing.host)


@pytest.fixture
def robot(shared_robot):
    yield shared_robot
    if shared_robot.read_once().robot_mode != pylibfranka.RobotMode.Idle:
        shared_robot.automatic_error_recovery()


def _provoke(robot, start, command, cycles=1500) -> str:
    """Run `command(k, state, first_state)` until the robot aborts; return the exception text."""
    control = start()
    first, _ = control.readOnce()
    with pytest.raises(pylibfranka.ControlException) as info:
        for k in range(cycles):
            state, _ = control.readOnce()
            control.writeOnce(command(k, state, first))
    del control
    return str(info.value)


def _assert_named_and_recover(robot, text: str, *names: str) -> None:
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Reflex
    for name in names:
        assert name in text
        assert name in str(state.last_motion_errors)
    robot.automatic_error_recovery()
    robot.read_once()  # drains what queued up while recovery waited for the arm to stop
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle and not bool(state.current_errors)


def _joint(q):
    return pylibfranka.JointPositions(list(q))


def test_step_in_q_c_is_a_velocity_discontinuity(robot):
    def step(k, state, first):
        q = np.array(first.q_d)
        q[3] += 0.05 if k > 5 else 0.0
        return _joint(q)

    text = _provoke(robot, lambda: robot.start_joint_position_control(JI), step)
    _assert_named_and_recover(robot, text, "joint_motion_generator_velocity_discontinuity")


def test_all_zero_q_c_breaks_the_joint_ranges(robot):
    def zeros(k, state, first):
        return _joint(np.zeros(7) if k > 5 else first.q_d)

    text = _provoke(robot, lambda: robot.start_joint_position_control(JI), zeros)
    _assert_named_and_recover(robot, text, "joint_motion_generator_position_limits_violation")


def test_first_q_c_away_from_q_is_an_invalid_start_pose(robot):
    def off(k, state, first):
        q = np.array(first.q_d)
        q[0] += 0.1
        return _joint(q)

    text = _provoke(robot, lambda: robot.start_joint_position_control(JI), off)
    _assert_named_and_recover(robot, text, "joint_position_motion_generator_start_pose_invalid")


def test_step_in_dq_c_is_an_acceleration_discontinuity(robot):
    def step(k, state, first):
        return pylibfranka.JointVelocities([0, 0, 0, 0.1 if k > 5 else 0.0, 0, 0, 0])

    text = _provoke(robot, lambda: robot.start_joint_velocity_control(JI), step)
    _assert_named_and_recover(robot, text, "joint_motion_generator_acceleration_discontinuity")


def test_smoothly_too_fast_joint_velocity_latches_both_names(robot):
    def ramp(k, state, first):  # joint 1 to 3 rad/s (limit 2.62) within accel and jerk limits
        v = 3.0 * (1 - math.cos(math.pi * min(k / 600, 1.0))) / 2
        return pylibfranka.JointVelocities([v, 0, 0, 0, 0, 0, 0])

    text = _provoke(robot, lambda: robot.start_joint_velocity_control(JI), ramp)
    _assert_named_and_recover(robot, text, "joint_motion_generator_velocity_limits_violation",
                              "joint_velocity_violation")


def _cartesian(T):
    return pylibfranka.CartesianPose(np.asarray(T).ravel(order="F").tolist())


def test_step_in_the_pose_is_a_cartesian_velocity_discontinuity(robot):
    def step(k, state, first):
        T = pose(first.O_T_EE_c)
        T[0, 3] += 0.02 if k > 5 else 0.0
        return _cartesian(T)

    text = _provoke(robot, lambda: robot.start_cartesian_pose_control(JI), step)
    _assert_named_and_recover(robot, text, "cartesian_motion_generator_velocity_discontinuity")


def test_first_pose_away_from_the_robot_is_an_invalid_start(robot):
    def off(k, state, first):
        T = pose(first.O_T_EE_c)
        T[2, 3] += 0.05
        return _cartesian(T)

    text = _provoke(robot, lambda: robot.start_cartesian_pose_control(JI), off)
    _assert_named_and_recover(robot, text, "cartesian_position_motion_generator_start_pose_invalid")


def test_step_in_the_twist_is_a_cartesian_acceleration_discontinuity(robot):
    def step(k, state, first):
        return pylibfranka.CartesianVelocities([0.05 if k > 5 else 0.0, 0, 0, 0, 0, 0])

    text = _provoke(robot, lambda: robot.start_cartesian_velocity_control(JI), step)
    _assert_named_and_recover(robot, text, "cartesian_motion_generator_acceleration_discontinuity")


def test_smoothly_too_fast_rotation_is_a_cartesian_velocity_limits_violation(robot):
    def spin(k, state, first):  # about the EE's own z axis (joint 7), up to 3 rad/s (limit 2.5)
        z = pose(first.O_T_EE)[:3, 2]
        w = 3.0 * (1 - math.cos(math.pi * min(k / 600, 1.0))) / 2
        return pylibfranka.CartesianVelocities([0, 0, 0, *(w * z)])

    text = _provoke(robot, lambda: robot.start_cartesian_velocity_control(JI), spin)
    _assert_named_and_recover(robot, text, "cartesian_motion_generator_velocity_limits_violation")


def test_torque_step_is_a_controller_torque_discontinuity(robot):
    def step(k, state, first):
        return pylibfranka.Torques([0, 0, 0, 0, 0, 0, 5.0 if k > 5 else 0.0])

    text = _provoke(robot, robot.start_torque_control, step)
    _assert_named_and_recover(robot, text, "controller_torque_discontinuity")


def test_measured_overspeed_in_torque_mode_is_a_joint_velocity_violation(robot):
    def push(k, state, first):  # 900 Nm/s ramp to 10 Nm on the wrist: it spins up past 5.26 rad/s
        return pylibfranka.Torques([0, 0, 0, 0, 0, 0, min(0.9 * k, 10.0)])

    text = _provoke(robot, robot.start_torque_control, push, cycles=3000)
    _assert_named_and_recover(robot, text, "joint_velocity_violation")


def test_ik_output_is_held_to_the_scaled_joint_limits():
    with running_sim("--enforce-motion-limits", "--clock", "lockstep",
                     "--joint-discontinuity-scale", "0.001") as sim:
        robot = connect(sim.host)

        def glide(k, state, first):  # gentle in Cartesian terms, too much for 0.01 rad/s²
            T = pose(first.O_T_EE_c)
            T[0, 3] += 0.05 * (1 - math.cos(math.pi * min(k / 1000, 1.0))) / 2
            return _cartesian(T)

        text = _provoke(robot, lambda: robot.start_cartesian_pose_control(JI), glide)
        _assert_named_and_recover(robot, text,
                                  "cartesian_motion_generator_joint_velocity_discontinuity")


def test_without_enforcement_violations_are_logged_and_the_motion_goes_on(sim):
    robot = connect(sim.host)
    control = robot.start_joint_position_control(JI)
    first, _ = control.readOnce()
    for k in range(300):
        control.readOnce()
        q = np.array(first.q_d)
        q[3] += 0.01 if k > 50 else 0.0
        command = _joint(q)
        command.motion_finished = k == 299
        control.writeOnce(command)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
    lines = sim.wait_for_log("joint_motion_generator_velocity_discontinuity: joint 4 acceleration")
    assert lines and "> 10" in lines[0] and "not enforced" in lines[0]


def test_torque_over_the_urdf_effort_is_logged_not_aborted(sim):
    robot = connect(sim.host)
    control = robot.start_torque_control()
    control.readOnce()
    for k in range(40):
        control.readOnce()
        command = pylibfranka.Torques([0, 0, 0, 0, 0, 0, min(0.9 * k, 13.0)])
        command.motion_finished = k == 39
        control.writeOnce(command)
    assert sim.wait_for_log("tau_J_range_violation: joint 7")


def test_an_absurd_torque_saturates_at_the_motor_and_the_arm_stays_simulated(sim):
    """Limits only logged, a finite but absurd torque is applied as the motor can: at its
    limit (12 Nm on joint 7), so the wrist speeds up as 12 Nm drives it, the physics stays
    stable and every state stays finite."""
    robot = connect(sim.host)
    control = robot.start_torque_control()
    control.readOnce()
    asked, dq_7, t = [], [], []
    try:
        for k in range(120):
            state, _ = control.readOnce()
            asked.append(state.tau_J_d[6])
            dq_7.append(state.dq[6])
            t.append(state.time.to_sec())
            assert np.isfinite(state.q).all() and np.isfinite(state.tau_J).all()
            command = pylibfranka.Torques([0, 0, 0, 0, 0, 0, 1e6 if k < 100 else 0.0])
            command.motion_finished = k == 119
            control.writeOnce(command)
    except pylibfranka.FrankaException:
        pass  # the wrist at its stop may be taken for a collision: what came until then counts
    assert len(dq_7) > 20 and max(asked) == 1e6
    # 12 Nm on the wrist's ~0.076 kg·m² (link and rotor) is ~160 rad/s² (per simulated second:
    # a realtime client may skip a state); a million Nm would be ~1e7 rad/s², and MuJoCo would
    # report such a state unstable and reset it.
    acceleration = np.diff(dq_7[1:21]) / np.diff(t[1:21])
    assert 100.0 < acceleration.max() < 200.0
    state = robot.read_once()
    assert np.isfinite(state.q).all() and abs(state.q[6]) < 3.2  # within the wrist's range


DERIVED = ("q_d", "dq_d", "ddq_d", "tau_J_d", "O_T_EE_d", "O_dP_EE_d", "O_dP_EE_c", "O_ddP_EE_c",
           "elbow_d", "elbow_c", "delbow_c", "ddelbow_c", "q", "dq", "tau_J", "O_T_EE")


@pytest.mark.parametrize("generator", ["velocity", "cartesian"])
def test_an_absurd_finite_command_publishes_finite_states(generator):
    """Limits only logged, a joint velocity of 1e300 rad/s (or a twist of 1e300 m/s) is taken
    at ±1e6 in its unit, logged once: every signal derived from it stays finite in the state."""
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        if generator == "velocity":
            control = robot.start_joint_velocity_control(JI)
            absurd, zero = pylibfranka.JointVelocities, [0.0] * 7
            value = [1e300] + [0.0] * 6
        else:
            control = robot.start_cartesian_velocity_control(JI)
            absurd, zero = pylibfranka.CartesianVelocities, [0.0] * 6
            value = [1e300] + [0.0] * 5
        control.readOnce()
        seen = []
        try:
            for k in range(30):
                state, _ = control.readOnce()
                seen.append({name: np.asarray(getattr(state, name)) for name in DERIVED})
                command = absurd(value if 3 <= k < 6 else zero)
                command.motion_finished = k == 29
                control.writeOnce(command)
        except pylibfranka.ControlException:
            pass  # what the arm makes of it afterwards is not the point: what it published is
        del control, robot
        assert len(sim.log_matching("beyond ±1e+06 taken as ±1e+06")) == 1
    assert len(seen) > 6
    for state in seen:
        for name, value in state.items():
            assert np.isfinite(value).all(), name


def test_a_torque_step_reaches_the_joint_at_the_motors_rate():
    """Limits only logged, a 6 Nm step in joint 1's torque command is followed as the motor
    can, at 1000 Nm/s (1 Nm a cycle): tau_J changes by at most that each cycle, and carries the
    step once the ramp is done (lockstep: the client reads every cycle)."""
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        control = robot.start_torque_control()
        control.readOnce()
        tau_J = []
        for k in range(40):
            state, _ = control.readOnce()
            tau_J.append(state.tau_J[0])
            command = pylibfranka.Torques([6.0 if k >= 10 else 0.0] + [0.0] * 6)
            command.motion_finished = k == 39
            control.writeOnce(command)
        del control, robot
    change = np.diff(tau_J)
    assert np.abs(change).max() <= 1.0 + 1e-9  # a step, not at once (it would be ~6 Nm)
    assert tau_J[-1] - tau_J[10] > 3.0  # but all of it, once ramped


def test_a_jerk_in_the_ik_output_is_a_joint_acceleration_discontinuity():
    with running_sim("--enforce-motion-limits", "--clock", "lockstep",
                     "--joint-discontinuity-scale", "0.03") as sim:
        robot = connect(sim.host)

        def accelerate(k, state, first):  # 0.1 m/s² from rest: a jerk spike at the start
            T = pose(first.O_T_EE_c)
            T[0, 3] += 0.5 * 0.1 * (k * 1e-3) ** 2
            return _cartesian(T)

        text = _provoke(robot, lambda: robot.start_cartesian_pose_control(JI), accelerate)
        _assert_named_and_recover(robot, text,
                                  "cartesian_motion_generator_joint_acceleration_discontinuity")
