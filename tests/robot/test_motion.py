"""Motions through pylibfranka: modes, desired signals, finishing, stopping, lost clients."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.testing import running_sim


def _robot(host):
    return pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)


@pytest.fixture
def lockstep():
    with running_sim("--clock", "lockstep") as sim:
        yield sim


def test_joint_position_motion_tracks_and_reports_desired_signals(lockstep):
    robot = _robot(lockstep.host)
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    q0 = np.array(state.q_d)
    worst = 0.0
    for k in range(1, 1500):
        state, _ = control.readOnce()
        assert state.robot_mode == pylibfranka.RobotMode.Move
        worst = max(worst, float(np.max(np.abs(np.array(state.q) - np.array(state.q_d)))))
        t = k * 1e-3
        q = q0.copy()
        q[6] += 0.2 * (1 - np.cos(np.pi * t / 1.5)) / 2
        command = pylibfranka.JointPositions(q.tolist())
        command.motion_finished = k == 1499
        control.writeOnce(command)
    assert worst < 2e-3
    final = robot.read_once()
    assert final.robot_mode == pylibfranka.RobotMode.Idle
    assert abs(final.q[6] - (q0[6] + 0.2)) < 1e-3
    assert final.control_command_success_rate == 0.0


def test_joint_velocity_motion_reports_commanded_velocity(lockstep):
    robot = _robot(lockstep.host)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()
    seen = []
    for k in range(1, 1000):
        state, _ = control.readOnce()
        seen.append((state.dq_d[3], state.dq[3]))
        w = 0.3 * np.sin(np.pi * k / 999)
        command = pylibfranka.JointVelocities([0, 0, 0, w, 0, 0, 0])
        command.motion_finished = k == 999
        control.writeOnce(command)
    dq_d, dq = np.array(seen).T
    assert dq_d.max() > 0.25  # the desired velocity follows the (filtered) command
    assert np.max(np.abs(dq - dq_d)) < 0.05
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_zero_torque_floats_in_gravity_compensation(lockstep):
    robot = _robot(lockstep.host)
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    q0 = np.array(state.q)
    for k in range(500):
        state, _ = control.readOnce()
        command = pylibfranka.Torques([0.0] * 7)
        command.motion_finished = k == 499
        control.writeOnce(command)
    assert np.max(np.abs(np.array(state.q) - q0)) < 1e-6
    np.testing.assert_allclose(state.tau_J_d, 0.0)


def test_torque_drives_the_arm(lockstep):
    robot = _robot(lockstep.host)
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    q0 = np.array(state.q)
    for k in range(300):
        state, _ = control.readOnce()
        command = pylibfranka.Torques([0, 0, 0, 0, 0, 0, 0.5 if k < 150 else -0.5])
        command.motion_finished = k == 299
        control.writeOnce(command)
        if k == 100:
            np.testing.assert_allclose(state.tau_J_d[6], 0.5)
    assert state.q[6] - q0[6] > 0.01  # +0.5 Nm on the wrist turned it positively


def test_stop_is_answered_when_idle(robot):
    robot.stop()
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_communication_violation_aborts_and_needs_recovery():
    with running_sim("--enforce-comm-constraints") as sim:
        robot = _robot(sim.host)
        control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
        with pytest.raises(pylibfranka.ControlException, match="communication_constraints_violation"):
            for k in range(2000):
                control.readOnce()
                if k == 50:
                    time.sleep(0.1)  # the client stalls: 100 cycles unanswered
                control.writeOnce(pylibfranka.JointVelocities([0.0] * 7))
        del control
        state = robot.read_once()
        assert state.robot_mode == pylibfranka.RobotMode.Reflex
        assert "communication_constraints_violation" in str(state.last_motion_errors)
        with pytest.raises(pylibfranka.CommandException, match="rejected"):
            robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
        robot.automatic_error_recovery()
        state = robot.read_once()
        assert state.robot_mode == pylibfranka.RobotMode.Idle
        assert not bool(state.current_errors)
        control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
        control.readOnce()
        finish = pylibfranka.JointVelocities([0.0] * 7)
        finish.motion_finished = True
        control.writeOnce(finish)


def test_without_enforcement_a_stall_only_lowers_the_success_rate(sim):
    robot = _robot(sim.host)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    rates = []
    for k in range(400):
        state, _ = control.readOnce()
        rates.append(state.control_command_success_rate)
        if k == 100:
            time.sleep(0.05)
        command = pylibfranka.JointVelocities([0.0] * 7)
        command.motion_finished = k == 399
        control.writeOnce(command)
    assert min(rates[101:]) < 0.8  # the stall shows in the reported rate
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_in_lockstep_a_descheduled_client_loses_no_cycle(lockstep):
    """The lockstep counterpart of the stall above: the next cycle waits for the answer, so a
    client that pauses 50 ms (a busy machine, a slow callback) sees consecutive states and
    loses nothing."""
    robot = _robot(lockstep.host)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()
    times, rates = [], []
    for k in range(300):
        state, _ = control.readOnce()
        times.append(round(state.time.to_sec() * 1000))
        rates.append(state.control_command_success_rate)
        if k in (100, 200):
            time.sleep(0.05)
        command = pylibfranka.JointVelocities([0.0] * 7)
        command.motion_finished = k == 299
        control.writeOnce(command)
    assert np.all(np.diff(times) == 1)
    assert min(rates[100:]) == 1.0


CRASHING_CLIENT = textwrap.dedent("""
    import os, signal, sys, pylibfranka
    robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = control.readOnce()
    print(state.q[6], flush=True)
    for k in range(300):
        state, _ = control.readOnce()
        control.writeOnce(pylibfranka.JointVelocities([0, 0, 0, 0, 0, 0, min(k, 200) * 0.002]))
    print(state.q[6], flush=True)
    if sys.argv[2] == "exit":
        os._exit(3)  # vanish mid-motion, moving at 0.4 rad/s
    os.kill(os.getpid(), signal.SIGSTOP)  # fall silent mid-motion, the connection still open
""")


def _at_rest_where_the_client_left_it(robot, first_q7: float, last_q7: float):
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    t0 = state.time.to_sec()
    while state.time.to_sec() - t0 < 0.5:
        state = robot.read_once()
    assert np.max(np.abs(state.dq)) < 1e-3
    assert last_q7 - first_q7 > 0.07  # the client had turned joint 7 (0.08 rad by its count)
    # carried on and braked, as the robot stops a motion it lost: 20 extrapolated cycles at
    # 0.4 rad/s (8 mrad), then the stop at 10 rad/s² (8 mrad); held there, not sprung back
    assert 0.012 < state.q[6] - last_q7 < 0.03


def test_a_client_that_vanishes_mid_motion_leaves_an_arm_at_rest(sim):
    done = subprocess.run([sys.executable, "-c", CRASHING_CLIENT, sim.host, "exit"], timeout=60,
                          capture_output=True, text=True)
    assert done.returncode == 3
    first_q7, last_q7 = map(float, done.stdout.split())
    assert sim.wait_for_log("disconnected")
    robot = _robot(sim.host)  # the next client gets in at once
    _at_rest_where_the_client_left_it(robot, first_q7, last_q7)


KILLED_CLIENT = textwrap.dedent("""
    import sys, pylibfranka
    robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()
    k = 0
    while True:  # joint 7 up to 0.3 rad/s at 1 rad/s², then on at 0.3 rad/s until it is killed
        state, _ = control.readOnce()
        print(state.q[6], flush=True)
        control.writeOnce(pylibfranka.JointVelocities([0, 0, 0, 0, 0, 0, min(k, 300) * 0.001]))
        k += 1
""")


def test_a_client_killed_mid_motion_leaves_the_arm_braked_to_rest(lockstep):
    """SIGKILL mid-motion (the kernel closes its connection): the robot runs the motion on for
    the 20 cycles it tolerates, brakes the arm to rest and reports idle; the next client gets
    in at once and finds it at rest. (Lockstep: the client is killed at a known cycle.)"""
    killed = subprocess.Popen([sys.executable, "-c", KILLED_CLIENT, lockstep.host],
                              stdout=subprocess.PIPE, text=True)
    try:
        seen = [float(killed.stdout.readline()) for _ in range(400)]  # 100 cycles at 0.3 rad/s
        killed.send_signal(signal.SIGKILL)
        killed.wait(timeout=10)
        seen += map(float, killed.stdout.read().split())
    finally:
        killed.kill()
    robot = _robot(lockstep.host)  # at once: no waiting for the server to notice
    state = robot.read_once()
    assert state.robot_mode == pylibfranka.RobotMode.Idle
    assert np.max(np.abs(state.dq)) == 0.0  # exactly at rest
    # 20 cycles on at 0.3 rad/s (6 mrad), then a stop over ~5 mrad; held where it stopped
    assert 0.008 < state.q[6] - seen[-1] < 0.02
    _still_motion(robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance))
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def _still_motion(control, cycles: int = 20) -> None:
    """A joint-velocity motion that stands still for `cycles` and finishes."""
    for k in range(cycles):
        control.readOnce()
        command = pylibfranka.JointVelocities([0.0] * 7)
        command.motion_finished = k == cycles - 1
        control.writeOnce(command)


PAUSING_CLIENT = textwrap.dedent("""
    import os, signal, sys, pylibfranka
    robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()
    for k in range(300):
        control.readOnce()
        if k == 100:
            os.kill(os.getpid(), signal.SIGSTOP)  # as a debugger's breakpoint would
        command = pylibfranka.JointVelocities([0.0] * 7)
        command.motion_finished = k == 299
        control.writeOnce(command)
    print(robot.read_once().robot_mode, flush=True)
""")


def test_a_client_paused_for_seconds_carries_on_when_nobody_replaces_it(sim):
    paused = subprocess.Popen([sys.executable, "-c", PAUSING_CLIENT, sim.host],
                              stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not _stopped(paused.pid) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert sim.wait_for_log("client silent for 20 cycles")  # held, not given up
        time.sleep(1.0)
        paused.send_signal(signal.SIGCONT)
        out, _ = paused.communicate(timeout=60)
    finally:
        paused.kill()
    assert paused.returncode == 0 and out.strip() == "RobotMode.Idle"


def _stopped(pid: int) -> bool:
    with open(f"/proc/{pid}/stat") as stat:
        return stat.read().rsplit(")", 1)[1].split()[0] == "T"


def test_a_client_silent_mid_motion_is_replaced_by_the_next_one(lockstep):
    """UDP silence with the connection open (a frozen process, a vanished host): after 20 lost
    cycles the arm holds, and the next client to connect takes the silent one's place.
    (Lockstep: a busy machine cannot make the client fall silent before it means to.)"""
    sim = lockstep
    silent = subprocess.Popen([sys.executable, "-c", CRASHING_CLIENT, sim.host, "stop"],
                              stdout=subprocess.PIPE, text=True)
    try:
        first_q7, last_q7 = float(silent.stdout.readline()), float(silent.stdout.readline())
        deadline = time.monotonic() + 30
        while not _stopped(silent.pid) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert sim.wait_for_log("client silent for 20 cycles", timeout=30)  # 20 × 100 ms
        robot = _robot(sim.host)
        assert sim.wait_for_log("silent mid-motion: closed to admit")
        _at_rest_where_the_client_left_it(robot, first_q7, last_q7)
        _still_motion(robot.start_joint_velocity_control(  # and it moves as any client does
            pylibfranka.ControllerMode.JointImpedance))
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
    finally:
        silent.kill()
        silent.wait(timeout=10)


def test_a_busy_client_is_not_replaced(lockstep):
    """Only a silent client is replaced: one that answers keeps the robot, the newcomer is
    turned away. (Lockstep: the cycles wait while this thread tries to connect.)"""
    robot = _robot(lockstep.host)
    control = robot.start_joint_velocity_control(pylibfranka.ControllerMode.JointImpedance)
    control.readOnce()
    with pytest.raises(pylibfranka.NetworkException):
        _robot(lockstep.host)
    _still_motion(control)
    assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_after_a_motion_the_idle_arm_comes_exactly_to_rest(lockstep):
    """The idle hold's standstill band: an arm that has moved stops trembling (at ~1e-13 rad/s
    of round-off) and holds bit-exactly still, as an arm that never moved does."""
    from support.clients import move_to

    robot = _robot(lockstep.host)
    target = np.array([0.1, -0.6, 0.1, -2.2, 0.05, 1.7, 0.9])
    move_to(robot, target, 1.0)
    start = robot.read_once().time.to_sec()
    state = robot.read_once()
    while state.time.to_sec() - start < 3.0:  # 3 s of robot time to settle
        time.sleep(0.2)
        state = robot.read_once()
    later = robot.read_once()
    while later.time.to_sec() - state.time.to_sec() < 0.05:
        later = robot.read_once()
    assert np.array_equal(np.asarray(later.q), np.asarray(state.q))
    assert np.array_equal(np.asarray(later.tau_J), np.asarray(state.tau_J))
    assert not np.asarray(later.dq).any() and not np.asarray(later.dtau_J).any()
    assert np.abs(np.asarray(later.q) - target).max() < 2e-3
