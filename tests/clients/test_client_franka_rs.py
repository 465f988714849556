"""franka-rs 0.4.0 (`import franka`) against the simulator: an independent Rust implementation of
the FCI protocol (v10 robot, v3 gripper) with Python bindings — no libfranka anywhere.

It checks what libfranka happens to tolerate: datagram sizes exactly (its receive buffer is one
byte larger than a state), status values, the order of mode transitions. Its Python API is
target control: `Robot.joint_targets()` / `Robot.cartesian_targets()` start a 1 kHz loop on a
Rust thread that streams toward a target. `backend="robot"` makes that loop a joint-position or
Cartesian-pose motion generator for the robot's internal controller; the default
`backend="impedance"` is torque control (the external controller) with the crate's own
impedance law. Everything releases the GIL, so it runs in the test process; the simulator is a
`running_sim` subprocess, lockstep-clocked for motions, and assertions are on robot state and
robot time (wall clock only bounds waits, against a dead server).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from franka_sim.testing import running_sim

franka = pytest.importorskip("franka", reason="franka-rs is not installed")
if not hasattr(franka, "Robot") or not hasattr(franka.Robot, "joint_targets"):
    pytest.skip("`franka` is not franka-rs", allow_module_level=True)

READY = np.array([0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4])
SINGULAR_POSE = np.array([0.0, 0.0, 0.0, -0.5, 0.0, 1.0, math.pi / 4])  # wrist centre over joint 1
WALL_TIMEOUT = 120.0  # a safety net against a dead server, never a timing bound


@pytest.fixture
def lockstep_sim():
    with running_sim("--clock", "lockstep") as sim:
        yield sim


def connect(host: str):
    return franka.Robot(host, realtime="ignore")


def fresh(robot):
    """A state published after this call began. read_once keeps the newest *queued* datagram, and a
    socket nobody read for a while holds old ones (it drops the newest when it overflows): the
    first read drains them, the second is current."""
    robot.read_once()
    return robot.read_once()


def wait_for(control, done, robot_seconds: float):
    """Poll a running target control until `done(state)` or `robot_seconds` of robot time passed."""
    start = control.state().time
    deadline = time.monotonic() + WALL_TIMEOUT
    while True:
        state = control.state()
        if done(state) or state.time - start > robot_seconds:
            return state
        assert control.running, "the target control ended by itself"
        assert time.monotonic() < deadline, "robot time stopped advancing"
        time.sleep(0.005)


def at_joint_target(target, tol=1e-3):
    return lambda s: np.abs(s.q - target).max() < tol and np.abs(s.dq).max() < 1e-3


def at_position(target, tol=1e-3):
    return lambda s: np.linalg.norm(s.O_T_EE[:3, 3] - target) < tol and np.abs(s.dq).max() < 1e-3


def move_joints(robot, target, **kwargs):
    """Joint-position motion (the robot's own controller) to `target`, finished at rest."""
    with robot.joint_targets(backend="robot", max_deviation=3.0, **kwargs) as arm:
        arm.move_to(target)
        wait_for(arm, at_joint_target(target), 20.0)


def rotation_angle(a, b) -> float:
    """Angle between two rotations (from the chord, exact near zero where arccos(trace) is not)."""
    chord = np.linalg.norm(np.asarray(a)[:3, :3] - np.asarray(b)[:3, :3]) / (2 * math.sqrt(2))
    return float(2 * np.arcsin(min(chord, 1.0)))


def quaternion_matrix(xyzw) -> np.ndarray:
    x, y, z, w = xyzw
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def test_connect_and_read_state(lockstep_sim):
    robot = connect(lockstep_sim.host)
    assert robot.fci_version == 10 and robot.server_version == 10
    state = fresh(robot)
    assert np.allclose(state.q, READY, atol=1e-3)
    assert np.allclose(state.q_d, state.q, atol=1e-6)
    assert np.abs(state.dq).max() < 1e-3
    assert state.robot_mode == "idle"
    assert state.current_errors == [] and state.last_motion_errors == []
    T = state.O_T_EE
    assert np.allclose(T[3], [0, 0, 0, 1]) and np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-5)
    assert state.m_ee == pytest.approx(0.73, abs=0.01)  # the Franka Hand
    assert state.accelerometer_top.shape == (6, 3)
    assert state.flat().shape == (franka.FLAT_LEN,)
    steps = np.diff([robot.read_once().time for _ in range(50)]) / 1e-3
    # time is message_id in ms: strictly increasing on the 1 ms grid (a slow reader skips some)
    assert np.all(steps >= 1 - 1e-6) and np.allclose(steps, np.round(steps), atol=1e-6)


def test_model_agrees_with_the_state(lockstep_sim):
    robot = connect(lockstep_sim.host)
    model = robot.model()  # built from the URDF the robot serves (GetRobotModel)
    state = fresh(robot)
    ee = model.pose("ee", state.q, state.F_T_EE, state.EE_T_K)
    assert np.allclose(ee, state.O_T_EE, atol=1e-5)
    flange = model.pose("flange", state.q)
    assert np.allclose(flange @ state.F_T_EE, state.O_T_EE, atol=1e-5)
    gravity = model.gravity(state.q, state.m_total, state.F_x_Ctotal)
    assert np.allclose(gravity, state.tau_J, atol=0.05)  # at rest the joints carry gravity only
    assert model.zero_jacobian("ee", state.q, state.F_T_EE).shape == (6, 7)
    assert model.mass(state.q).shape == (7, 7)


def test_joint_position_motion(lockstep_sim):
    robot = connect(lockstep_sim.host)
    target = READY + np.array([0.1, -0.1, 0.1, 0.1, -0.1, 0.1, 0.2])
    with robot.joint_targets(backend="robot") as arm:
        arm.move_to(target)
        assert np.allclose(arm.target(), target)
        reached = wait_for(arm, at_joint_target(target), 20.0)
        assert reached.robot_mode == "move"
        arm.stop()
    state = fresh(robot)
    assert state.robot_mode == "idle" and state.current_errors == []
    assert np.allclose(state.q, target, atol=1e-3)


def test_joint_chunk_is_followed_to_its_last_row(lockstep_sim):
    robot = connect(lockstep_sim.host)
    rows = READY + np.outer(np.linspace(0.02, 0.1, 5), [1, 0, 1, 0, 1, 0, 1])
    with robot.joint_targets(backend="robot") as arm:
        arm.follow(rows, dt=0.02)
        wait_for(arm, at_joint_target(rows[-1]), 20.0)
    assert np.allclose(fresh(robot).q, rows[-1], atol=1e-3)


def test_joint_impedance_torque_motion(lockstep_sim):
    robot = connect(lockstep_sim.host)
    target = READY + np.array([0.1, -0.1, 0.1, 0.1, -0.1, 0.1, 0.2])
    with robot.joint_targets() as arm:  # backend="impedance": torques, the external controller
        arm.move_to(target)
        reached = wait_for(arm, at_joint_target(target, 2e-3), 20.0)
        assert reached.robot_mode == "move"
    state = fresh(robot)
    assert state.robot_mode == "idle" and state.current_errors == []
    assert np.allclose(state.q, target, atol=2e-3)


def test_torque_control_at_rest_holds_the_arm(lockstep_sim):
    """An impedance loop whose target is where the arm is commands (almost) zero torque: the
    robot carries gravity itself, so the arm must stay put for the whole second."""
    robot = connect(lockstep_sim.host)
    q0 = fresh(robot).q
    worst, tau = 0.0, 0.0
    with robot.joint_targets() as arm:
        start = arm.state().time
        deadline = time.monotonic() + WALL_TIMEOUT
        while (state := arm.state()).time - start < 1.0:
            worst = max(worst, float(np.abs(state.q - q0).max()))
            tau = max(tau, float(np.abs(state.tau_J_d).max()))
            assert state.robot_mode == "move" and time.monotonic() < deadline
            time.sleep(0.005)
    assert worst < 1e-4
    assert tau < 0.1
    assert fresh(robot).robot_mode == "idle"


@pytest.mark.parametrize("controller_mode", ["cartesian_impedance", "joint_impedance"])
def test_cartesian_pose_motion(lockstep_sim, controller_mode):
    robot = connect(lockstep_sim.host)
    start = fresh(robot).O_T_EE
    offset = np.array([0.05, 0.02, -0.03])  # base frame
    with robot.cartesian_targets(backend="robot", controller_mode=controller_mode) as arm:
        arm.move_by(offset)
        assert np.allclose(arm.target_pose()[:3, 3], start[:3, 3] + offset, atol=1e-6)
        wait_for(arm, at_position(start[:3, 3] + offset), 20.0)
    state = fresh(robot)
    assert state.robot_mode == "idle" and state.current_errors == []
    assert np.linalg.norm(state.O_T_EE[:3, 3] - start[:3, 3] - offset) < 2e-3
    assert rotation_angle(start, state.O_T_EE) < 5e-3


@pytest.mark.parametrize("backend", ["robot", "impedance"])
def test_cartesian_orientation_target(lockstep_sim, backend):
    """A 7-element target sets the orientation: the start yawed 10 degrees about base z."""
    robot = connect(lockstep_sim.host)
    with robot.cartesian_targets(backend=backend) as arm:
        start = arm.target()
        goal = franka.rotated(start[3:], [0.0, 0.0, math.radians(10.0)])
        arm.move_to(np.r_[start[:3], goal])
        R_goal = quaternion_matrix(goal)
        state = wait_for(arm, lambda s: rotation_angle(s.O_T_EE, R_goal) < 1e-3
                         and np.abs(s.dq).max() < 1e-3, 20.0)
    assert rotation_angle(state.O_T_EE, R_goal) < 2e-3
    assert np.linalg.norm(state.O_T_EE[:3, 3] - start[:3]) < 2e-3
    final = fresh(robot)
    assert final.robot_mode == "idle" and rotation_angle(final.O_T_EE, R_goal) < 2e-3


def test_cartesian_impedance_torque_motion(lockstep_sim):
    robot = connect(lockstep_sim.host)
    start = fresh(robot).O_T_EE
    offset = np.array([0.05, 0.02, -0.03])
    with robot.cartesian_targets() as arm:  # the crate's Cartesian impedance, sent as torques
        arm.move_by(offset)
        wait_for(arm, at_position(start[:3, 3] + offset, 2e-3), 20.0)
    state = fresh(robot)
    assert state.robot_mode == "idle"
    assert np.linalg.norm(state.O_T_EE[:3, 3] - start[:3, 3] - offset) < 3e-3
    assert rotation_angle(start, state.O_T_EE) < 1e-2


def test_setters_succeed_idle_and_are_refused_while_moving(lockstep_sim):
    robot = connect(lockstep_sim.host)
    robot.set_collision_behavior([20.0] * 7, [40.0] * 7, [10.0] * 7, [30.0] * 7,
                                 [20.0] * 6, [40.0] * 6, [10.0] * 6, [30.0] * 6)
    robot.set_collision_behavior_simple([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
    robot.set_joint_impedance([3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0])
    robot.set_cartesian_impedance([3000.0, 3000.0, 3000.0, 300.0, 300.0, 300.0])
    robot.automatic_error_recovery()  # nothing to recover: still kSuccess
    robot.stop()  # no motion: StopMove is answered all the same
    assert fresh(robot).robot_mode == "idle"
    with robot.joint_targets(backend="robot") as arm:
        arm.move_by([0.05, 0, 0, 0, 0, 0, 0])
        with pytest.raises(franka.FrankaError, match="not possible") as refused:
            robot.set_joint_impedance([3000.0] * 7)
        assert refused.value.kind == "command"
        wait_for(arm, at_joint_target(READY + [0.05, 0, 0, 0, 0, 0, 0]), 20.0)
    assert fresh(robot).robot_mode == "idle"


def test_stop_preempts_a_target_control(lockstep_sim):
    robot = connect(lockstep_sim.host)
    with pytest.raises(franka.ControlException, match="preempted"):
        # A tenth of the default velocity budget: the move takes ~5 s of robot time, so the
        # stop, which this thread sends once the arm is under way while franka-rs's own thread
        # drives the lockstep clock as fast as it answers, lands long before the target (~0.5 s
        # of wall time here; 0.06 s at the default, which a loaded machine overran).
        with robot.joint_targets(backend="robot", fraction=0.02) as arm:
            arm.move_by([0.3, 0, 0, 0, 0, 0, 0])
            wait_for(arm, lambda s: s.q[0] > 0.02, 20.0)
            robot.stop()
            deadline = time.monotonic() + WALL_TIMEOUT
            while arm.running and time.monotonic() < deadline:
                time.sleep(0.005)
            assert not arm.running
    state = fresh(robot)
    assert state.robot_mode == "idle" and state.current_errors == []
    assert 0.02 < state.q[0] < 0.3
    move_joints(robot, READY)  # and it moves again
    assert np.allclose(fresh(robot).q, READY, atol=1e-3)


def test_cartesian_motion_from_a_singular_pose_is_refused(lockstep_sim):
    robot = connect(lockstep_sim.host)
    move_joints(robot, SINGULAR_POSE, fraction=0.3)
    before = fresh(robot)
    assert np.allclose(before.q, SINGULAR_POSE, atol=1e-3)
    with pytest.raises(franka.FrankaError, match="singular pose") as refused:
        with robot.cartesian_targets(backend="robot") as arm:
            arm.move_by([0.0, 0.0, 0.02])
    assert refused.value.kind == "command"
    assert not isinstance(refused.value, franka.ControlException)  # refused, never started
    state = fresh(robot)
    assert state.robot_mode == "idle" and state.current_errors == [] and state.last_motion_errors == []
    assert np.allclose(state.q, before.q, atol=1e-4)
    move_joints(robot, READY, fraction=0.3)
    assert np.allclose(fresh(robot).q, READY, atol=1e-3)


def test_reflex_then_automatic_error_recovery():
    """With motion limits enforced and the IK's joint acceleration/jerk budget scaled down 1000x,
    any Cartesian motion trips a cartesian_motion_generator_joint_* reflex at once."""
    with running_sim("--clock", "lockstep", "--enforce-motion-limits",
                     "--joint-discontinuity-scale", "0.001") as sim:
        robot = connect(sim.host)
        with pytest.raises(franka.ControlException, match="reflex") as aborted:
            with robot.cartesian_targets(backend="robot") as arm:
                arm.move_by([0.05, 0.0, 0.0])
                deadline = time.monotonic() + WALL_TIMEOUT
                while arm.running and time.monotonic() < deadline:
                    time.sleep(0.005)
        assert aborted.value.errors and all(
            name.startswith("cartesian_motion_generator_joint_") for name in aborted.value.errors)
        state = fresh(robot)
        assert state.robot_mode == "reflex"
        assert state.current_errors == aborted.value.errors
        assert state.last_motion_errors == aborted.value.errors
        with pytest.raises(franka.FrankaError, match="Reflex"):
            with robot.joint_targets(backend="robot"):
                pass
        robot.automatic_error_recovery()
        state = fresh(robot)
        assert state.robot_mode == "idle" and state.current_errors == []
        assert state.last_motion_errors == aborted.value.errors  # kept until the next motion
        # A motion starts again. It holds still: with limits enforced, a cycle lost to host
        # load while the generator moves would itself be a discontinuity.
        with robot.joint_targets(backend="robot") as arm:
            assert wait_for(arm, lambda s: s.robot_mode == "move", 1.0).robot_mode == "move"
        assert fresh(robot).robot_mode == "idle"
        assert sim.log_matching("cartesian_motion_generator_joint_")


def test_gripper(lockstep_sim):
    robot = connect(lockstep_sim.host)
    gripper = robot.gripper()
    assert gripper.server_version == 3
    first = gripper.read_once()
    assert first.width == pytest.approx(0.08) and not first.is_grasped
    assert gripper.homing() is True
    homed = gripper.read_once()
    assert 0.079 <= homed.max_width <= 0.083 and homed.time > first.time
    assert gripper.move(0.04, 0.05) is True
    assert gripper.read_once().width == pytest.approx(0.04, abs=1e-3)
    assert gripper.grasp(0.02, 0.05, 20.0) is False  # nothing between the fingers: kUnsuccessful
    missed = gripper.read_once()
    assert not missed.is_grasped and missed.width < 0.02 - 0.005
    assert gripper.move(0.08, 0.1) is True
    with pytest.raises(franka.FrankaError, match="Command failed") as failed:
        gripper.move(0.5, 0.05)
    assert failed.value.kind == "command"
    times = [gripper.read_once().time for _ in range(3)]
    assert times == sorted(times) and len(set(times)) == 3
    assert fresh(robot).robot_mode == "idle"  # the arm's connection is untouched by all this
