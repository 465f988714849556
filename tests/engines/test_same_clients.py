"""The same pylibfranka programs on each physics engine, in lockstep: joint position and
velocity motions, a torque hold, a Cartesian pose motion, a press on the table until the
reflex, the Hand's homing and a grasp of the scene's cube; the client's Model equals each
engine's own dynamics; and the engines end the programs in the same poses (TOLERANCES, stated
in docs/engines.md).

Each engine serves one world for the module (the programs run in order, each from READY); the
programs are the examples' and tests/support's functions, called alike for both.
"""

from __future__ import annotations

import gc
import math

import numpy as np
import pylibfranka
import pytest

from engine_params import ENGINES, engine_server
from support.clients import connect, move_to, pose, press_until_reflex
from franka_sim.control import Control

import generate_cartesian_pose_motion
import generate_joint_velocity_motion
import pick_and_place as pp

# Where the engines may end the same program apart: joint angles (rad), the end effector's
# position (m), the Hand's opening on the cube (m), the grasped cube's position (m). The arm's
# programs end within ~1e-6 of each other; a grasp's contacts differ more (docs/engines.md).
TOLERANCES = {"q": 1e-4, "position": 1e-4, "width": 1e-3, "cube": 1e-2}
# The client's Model against the engine's own M, g and c (relative), as tests/physics checks
# MuJoCo's.
MODEL_AGREEMENT = 1e-6
K_THETA = np.array([3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0])
CUBE_MASS = 0.1  # kg (scenes/default.xml)

RESULTS: dict[str, dict[str, np.ndarray]] = {}  # engine → program → where it ended


@pytest.fixture(scope="module", params=ENGINES)
def sim(request):
    engine = request.param
    server = engine_server(engine)
    server.engine = engine
    RESULTS.setdefault(engine, {})
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def robot(sim):
    """A pylibfranka Robot for the test, gone after it (the next test connects its own)."""
    robot = connect(sim.host)
    yield robot
    del robot
    gc.collect()


def _ended(sim, program: str, value) -> None:
    RESULTS[sim.engine][program] = np.asarray(value, dtype=float)


def test_joint_position_motion_reaches_its_target(sim, robot):
    target = pp.READY + np.array([0.3, 0.2, -0.2, 0.3, 0.2, -0.2, 0.3])
    q = move_to(robot, target, seconds=1.0)
    assert np.abs(q - target).max() < 1e-3
    _ended(sim, "joint position", q)


def _at_ready(host: str):
    """The arm moved to READY by a client that is gone afterwards; the state it left."""
    robot = connect(host)
    move_to(robot, pp.READY, seconds=1.0)
    return _state(host, robot)


def _state(host: str, robot=None):
    """The robot's state, read by a client that is gone afterwards."""
    robot = robot or connect(host)
    state = robot.read_once()
    del robot
    gc.collect()
    return state


def test_joint_velocity_motion_swings_and_stops(sim):
    _at_ready(sim.host)
    generate_joint_velocity_motion.main(sim.host)  # 2 s there and back
    gc.collect()
    state = _state(sim.host)
    assert np.abs(np.array(state.dq)).max() < 1e-3
    assert np.abs(np.array(state.q) - pp.READY).max() < 0.05
    _ended(sim, "joint velocity", state.q)


def test_torque_control_with_zero_torque_holds_the_arm(sim, robot):
    """The robot adds gravity compensation: a client commanding zero torque holds still."""
    move_to(robot, pp.READY, seconds=1.0)
    control = robot.start_torque_control()
    state, _ = control.readOnce()
    start, t = np.array(state.q), 0.0
    while True:
        state, period = control.readOnce()
        t += period.to_sec()
        torques = pylibfranka.Torques([0.0] * 7)
        torques.motion_finished = t >= 1.0
        control.writeOnce(torques)
        if torques.motion_finished:
            break
    del control
    q = np.array(robot.read_once().q)
    assert np.abs(q - start).max() < 1e-3
    _ended(sim, "torque hold", q)


def test_a_declared_load_that_is_not_carried_reads_as_external(sim, robot):
    """SetLoad of 1 kg with nothing carried: the robot's gravity compensation, which includes
    it, lifts the arm until the joint springs hold it, and the estimate reads the robot pushing
    down with the missing weight."""
    move_to(robot, pp.READY, seconds=1.0)
    robot.set_joint_impedance(K_THETA.tolist())
    before = _settled(robot)
    robot.set_load(1.0, [0.0, 0.0, 0.1], [0.004, 0.0, 0.0, 0.0, 0.005, 0.0, 0.0, 0.0, 0.003])
    state = _settled(robot)
    tau_ext = np.array(state.tau_ext_hat_filtered)
    lift = np.array(state.q) - np.array(before.q)
    assert np.abs(tau_ext).max() > 1.0
    np.testing.assert_allclose(K_THETA * lift, -tau_ext, atol=0.02)
    np.testing.assert_allclose(state.O_F_ext_hat_K[:3], [0.0, 0.0, -9.81], atol=0.05)
    robot.set_load(0.0, [0.0, 0.0, 0.0], [0.0] * 9)
    state = _settled(robot)
    np.testing.assert_allclose(state.q, before.q, atol=1e-5)
    assert np.abs(state.tau_ext_hat_filtered).max() < 1e-3
    _ended(sim, "declared load", lift)


def _settled(robot, reads: int = 50):
    """The state after the world came to rest (lockstep: the reads follow it)."""
    for _ in range(reads):
        state = robot.read_once()
    return state


def test_cartesian_pose_motion_comes_back(sim):
    start = pose(_at_ready(sim.host).O_T_EE)
    generate_cartesian_pose_motion.main(sim.host, 2.0)  # a quarter circle and back
    gc.collect()
    end = pose(_state(sim.host).O_T_EE)
    assert np.abs(end[:3, 3] - start[:3, 3]).max() < 1e-3
    _ended(sim, "cartesian pose", end[:3, 3])


def test_a_press_on_the_table_ends_in_the_reflex(sim, robot):
    seen, force = press_until_reflex(robot, 20.0)  # asserts the cartesian_reflex itself
    assert any(contact == 1.0 for _, _, contact in seen)
    assert force < -2.0  # pressing down when the reflex came
    _ended(sim, "press", robot.read_once().q)


def test_a_reset_into_the_table_is_refused(sim):
    from franka_sim.control import Conflict

    with pytest.raises(Conflict, match=r"finger\d into scene/table"):
        Control(sim.host, timeout=300.0).reset(q=[0.0, 1.6, 0.0, -0.3, 0.0, 1.9, 0.78])


def test_what_nothing_moves_is_refused_alike_and_genesis_records_nothing(sim, tmp_path):
    """A push on the table or the arm's base, placing them, and placing the cube inside the
    Hand: 409 on either engine, saying why. A recording through the control API replays on
    MuJoCo: refused on Genesis."""
    from franka_sim.control import Conflict

    control = Control(sim.host, timeout=300.0)
    cube = control.pose("cube")["position"]
    with pytest.raises(Conflict, match="inside another body: scene/cube into "):
        control.set_pose("cube", control.pose("hand")["position"])
    assert control.pose("cube")["position"] == cube
    for body in ("scene/table", "link0"):
        with pytest.raises(Conflict, match="fixed to the world"):
            control.push(body, [0.0, 0.0, 10.0])
        with pytest.raises(Conflict, match="fixed to the world"):
            control.set_pose(body, [0.0, 0.0, 1.0])
    if sim.engine == "genesis":
        with pytest.raises(Conflict, match="replays on MuJoCo"):
            control.start_recording(str(tmp_path / "run.mcap"))
        assert not (tmp_path / "run.mcap").exists()


def test_the_hand_homes_and_grasps_the_cube(sim, robot):
    control = Control(sim.host, timeout=300.0)
    assert np.abs(np.array(control.pose("cube")["position"]) - pp.CUBE).max() < 1e-3
    gripper = pylibfranka.Gripper(sim.host)
    assert gripper.homing() is True
    assert gripper.read_once().max_width == pytest.approx(0.081, abs=2e-4)
    assert pp.pick(robot, gripper, pp.CUBE) is True
    held = gripper.read_once()
    assert held.is_grasped and held.width == pytest.approx(pp.CUBE_SIZE, abs=1e-3)
    # The cube's weight reaches the arm through the pads' contacts: the robot holds it up.
    weight = _settled(robot).O_F_ext_hat_K[:3]
    np.testing.assert_allclose(weight, [0.0, 0.0, CUBE_MASS * 9.81], atol=0.05)
    cube = np.array(control.pose("cube")["position"])
    assert cube[2] > pp.CUBE[2] + 0.1  # lifted with the arm
    _ended(sim, "grasp width", [held.width])
    _ended(sim, "grasped cube", cube)
    gripper.move(0.08, pp.SPEED)
    del gripper


def test_the_clients_model_is_the_engines_dynamics(sim, robot):
    from franka_sim.config import READY_POSE
    from franka_sim.description.urdf import default_urdf_text, load_arm_description
    from franka_sim.physics.engine_choice import make_physics
    from franka_sim.physics.fingers import FINGERS
    from franka_sim.physics.scene import ArmPlacement, default_scene_path

    desc = load_arm_description(default_urdf_text())
    physics = make_physics([ArmPlacement(desc, tool=FINGERS)], {"": np.array(READY_POSE)},
                           default_scene_path(), engine=sim.engine).arm(0)
    model, state = robot.load_model(), robot.read_once()
    tolerance = MODEL_AGREEMENT
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = desc.lower + (desc.upper - desc.lower) * rng.uniform(0.05, 0.95, 7)
        dq = rng.uniform(-1.0, 1.0, 7)
        state.q, state.dq = q.tolist(), dq.tolist()
        assert _rel(model.gravity(state), physics.gravity(q)) < tolerance
        M = np.reshape(model.mass(state), (7, 7), order="F")
        assert _rel(M, physics.mass_matrix(q)) < tolerance
        assert _rel(model.coriolis(state), physics.coriolis(q, dq)) < tolerance
        # The desired state's kinematics (every cycle of a motion) are the engine's own.
        O_T_F, J_F = physics.flange_pose_and_jacobian(q)
        np.testing.assert_allclose(O_T_F, physics.flange_pose(q), atol=1e-6)
        np.testing.assert_allclose(J_F, physics.jacobian_flange(q), atol=1e-6)


def _rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / max(np.linalg.norm(b), 1e-12))


@pytest.mark.genesis
def test_the_engines_end_the_programs_in_the_same_poses():
    if set(RESULTS) != {"mujoco", "genesis"} or len(RESULTS["genesis"]) < 8:
        pytest.skip("needs every program's end on both engines (genesis installed, none failed)")
    mujoco, genesis = RESULTS["mujoco"], RESULTS["genesis"]
    kinds = {"joint position": "q", "joint velocity": "q", "torque hold": "q",
             "declared load": "q",
             "cartesian pose": "position", "press": "q", "grasp width": "width",
             "grasped cube": "cube"}
    apart = {name: float(np.abs(mujoco[name] - genesis[name]).max()) for name in kinds}
    print("the engines apart:", apart)
    for name, kind in kinds.items():
        assert apart[name] < TOLERANCES[kind], apart
    assert math.isfinite(sum(apart.values()))


@pytest.mark.parametrize("engine", ENGINES)
def test_a_scenes_free_body_whose_joint_has_no_name_is_served(engine, tmp_path):
    """MJCF lets a free joint go unnamed (Genesis then names it after its body)."""
    scene = tmp_path / "unnamed.xml"
    scene.write_text(
        '<mujoco><worldbody><body name="cube" pos="0.45 0 0.3"><freejoint/>'
        '<geom type="box" size="0.025 0.025 0.025" mass="0.1"/></body></worldbody></mujoco>')
    server = engine_server(engine, "--scene", str(scene))
    try:
        control = Control(server.host, timeout=300.0)
        placed = control.set_pose("scene/cube", [0.5, 0.1, 0.4])
        assert np.allclose(placed["position"], [0.5, 0.1, 0.4])
        pushed = control.push("scene/cube", [0.0, 0.0, 0.5], duration=0.01)
        assert pushed["body"] == "scene/cube"
    finally:
        server.stop()
