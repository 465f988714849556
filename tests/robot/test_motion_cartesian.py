"""Cartesian generators through pylibfranka: IK tracking at the configured EE frame, the
elbow in the null space, the singular-start refusal, and the Cartesian impedance law."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pylibfranka
import pytest

from franka_sim.spatial import exp_rotation
from franka_sim.robot.settings import CollisionThresholds
from franka_sim.testing import running_sim
from support.clients import cartesian_pose_motion, connect, move_to, pose
from support.harness import Harness

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SINGULAR_POSE = [0.0, 0.0, 0.0, -0.5, 0.0, 1.0, np.pi / 4]  # wrist centre over joint 1


@pytest.fixture(scope="module")
def lockstep_sim():
    with running_sim("--clock", "lockstep") as sim:
        yield sim


def _run(name, host, *args, python=sys.executable):
    done = subprocess.run([python, str(EXAMPLES / f"{name}.py"), host, *args],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_cartesian_pose_example_tracks_within_a_millimetre(lockstep_sim):
    out = _run("generate_cartesian_pose_motion", lockstep_sim.host, "4")
    assert float(re.search(r"error ([0-9.]+) mm", out).group(1)) < 1.0


def test_cartesian_velocity_example_returns_to_its_start(lockstep_sim):
    out = _run("generate_cartesian_velocity_motion", lockstep_sim.host)
    offset = np.array(eval(out.split(":", 1)[1]))
    assert np.linalg.norm(offset) < 1e-3


def test_cartesian_impedance_example_holds_the_pose(lockstep_sim):
    out = _run("cartesian_impedance_control", lockstep_sim.host, "2")
    assert float(re.search(r"error ([0-9.]+) mm", out).group(1)) < 1.0


def test_elbow_moves_in_the_null_space(lockstep_sim):
    """pylibfranka's CartesianPose has no elbow; franky (libfranka too) drives this one."""
    out = _run("generate_elbow_motion", lockstep_sim.host, "0.3")
    rows = re.findall(r"q3 = (-?[0-9.]+) \(target (-?[0-9.]+)\); EE moved ([0-9.]+) mm", out)
    assert len(rows) == 2
    for q3, target, ee_moved in rows:
        assert abs(float(q3) - float(target)) < 5e-3
        assert float(ee_moved) < 1.0


def test_the_tracked_point_is_the_configured_end_effector(lockstep_sim):
    robot = connect(lockstep_sim.host)
    NE_T_EE = np.eye(4)
    NE_T_EE[0, 3] = 0.05  # a tool 5 cm off the flange axis
    robot.set_EE(NE_T_EE.ravel(order="F").tolist())
    state = robot.read_once()
    T0 = pose(state.O_T_EE)
    flange0 = T0 @ np.linalg.inv(pose(state.F_T_EE))
    # Spin the tool about its own z axis: its tip must stay put while the flange swings.
    targets = []
    for k in range(1500):
        T = T0.copy()
        T[:3, :3] = T0[:3, :3] @ exp_rotation(np.array([0, 0, 0.4 * (1 - np.cos(np.pi * k / 1499)) / 2]))
        targets.append(T)
    seen = cartesian_pose_motion(robot, targets)
    final = robot.read_once()
    tip_drift = max(np.linalg.norm(pose(s.O_T_EE)[:3, 3] - T0[:3, 3]) for s in seen)
    flange = pose(final.O_T_EE) @ np.linalg.inv(pose(final.F_T_EE))
    assert tip_drift < 1e-3
    assert np.linalg.norm(flange[:3, 3] - flange0[:3, 3]) > 0.01
    robot.set_EE(np.eye(4).ravel(order="F").tolist())


def test_cartesian_motion_refused_at_a_singular_pose_joint_motion_is_not():
    with running_sim("--clock", "lockstep") as sim:
        robot = connect(sim.host)
        q = move_to(robot, SINGULAR_POSE, 3.0)  # joint motions are never refused for it
        np.testing.assert_allclose(q, SINGULAR_POSE, atol=2e-3)
        with pytest.raises(pylibfranka.CommandException, match="singular"):
            robot.start_cartesian_pose_control(pylibfranka.ControllerMode.JointImpedance)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle


def test_cartesian_impedance_tracks_a_moving_pose_and_reports_its_torque(lockstep_sim):
    """Under kCartesianImpedance the robot tracks O_T_EE_d and O_dP_EE_d both: at 0.2 m/s the
    hand keeps within a millimetre or two of its desired pose (a damper on the velocity alone
    would leave it D/K × v, ~1 cm, behind). tau_J_d is the torque that controller asks for,
    what the joints then carry less gravity (tau_J − g(q))."""
    robot = connect(lockstep_sim.host)
    model = robot.load_model()
    T0 = pose(robot.read_once().O_T_EE)
    seconds = 1.5
    targets = []
    for k in range(int(seconds * 1000) + 1):
        T = T0.copy()
        T[1, 3] += 0.1 * (1 - np.cos(np.pi * k / 1000 / seconds))  # peak 0.21 m/s at 0.75 s
        targets.append(T)
    seen = cartesian_pose_motion(robot, targets, pylibfranka.ControllerMode.CartesianImpedance)
    cruising = seen[650:850]
    lag = max(abs(pose(s.O_T_EE_d)[1, 3] - pose(s.O_T_EE)[1, 3]) for s in cruising)
    assert lag < 0.003
    carried = max(np.max(np.abs(np.array(s.tau_J_d) - (np.array(s.tau_J) - model.gravity(s))))
                  for s in cruising)
    assert carried < 1.0
    assert max(np.max(np.abs(s.tau_J_d)) for s in cruising) > 0.05  # (not zero: it drives)


def _push_response(K_x, force, EE_T_K=np.eye(4), controller=1):
    """EE displacement under a constant external force on the hand (harness, no network)."""
    h = Harness()
    h.core.settings.set_cartesian_impedance(K_x)
    h.core.settings.EE_T_K = EE_T_K
    # A 10 N push is right at the default collision threshold: raise it, as a client would.
    h.core.settings.collision = CollisionThresholds(*(np.full(n, 100.0) for n in (7,) * 4 + (6,) * 4))
    h.move(controller, 0)
    h.cycle()
    q = np.array(h.state["q_d"], dtype=float)
    T0 = np.reshape(h.state["O_T_EE"], (4, 4), order="F").astype(float)
    hand = h.backend.model.body("hand").id
    for k in range(2500):
        h.backend.data.xfrc_applied[hand, :3] = force if k > 100 else 0.0
        h.send(q_c=q)
        h.cycle()
    T = np.reshape(h.state["O_T_EE"], (4, 4), order="F")
    return T[:3, 3] - T0[:3, 3]


def test_cartesian_impedance_is_a_spring_of_stiffness_K_x():
    dx = _push_response([1000, 1000, 1000, 100, 100, 100], [10.0, 0.0, 0.0])
    assert dx[0] == pytest.approx(10.0 / 1000, rel=0.1)


def test_stiffness_acts_along_the_axes_of_K():
    K_x = [3000, 300, 3000, 100, 100, 100]  # soft along K's y only
    EE_T_K = np.eye(4)
    EE_T_K[:3, :3] = exp_rotation(np.array([0, 0, np.pi / 2]))
    h = Harness()
    R_OK = np.reshape(h.state["O_T_EE"], (4, 4), order="F")[:3, :3].astype(float) @ EE_T_K[:3, :3]
    push = 10.0 * R_OK[:, 1]  # along K's y axis, in the base frame
    d = _push_response(K_x, push, EE_T_K)
    assert np.dot(d, R_OK[:, 1]) == pytest.approx(10.0 / 300, rel=0.1)


def test_joint_impedance_is_a_spring_of_stiffness_K_theta():
    h = Harness()
    h.core.settings.set_joint_impedance([3000, 3000, 3000, 2500, 2500, 2000, 200])
    h.move(0, 0)
    h.cycle()
    q = np.array(h.state["q_d"], dtype=float)
    hand = h.backend.model.body("hand").id
    # A pure torque about the flange z axis loads joint 7 only.
    z = np.reshape(h.state["O_T_EE"], (4, 4), order="F")[:3, 2].astype(float)
    for _ in range(2000):
        h.backend.data.xfrc_applied[hand, 3:] = 2.0 * z
        h.send(q_c=q)
        h.cycle()
    assert h.state["q"][6] - q[6] == pytest.approx(2.0 / 200, rel=0.05)
