"""Several arms in one world: each holds still under its own gravity compensation, moves only
under its own commands, and reports in its own base frame, as a lone arm does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import ArmPlacement, default_scene_path
from franka_sim.physics.world import World

PI = math.pi
DESC = load_arm_description(default_urdf_text())
HOME = np.array([0, -PI / 4, 0, -3 * PI / 4, 0, PI / 2, PI / 4])
K_IDLE = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
D_IDLE = np.array([60, 60, 50, 50, 30, 25, 15.0])
START = {"left": HOME, "right": HOME + np.array([0.3, 0.2, -0.1, 0.3, 0.2, -0.1, 0.4])}
ARMS = (ArmPlacement(DESC, "left", base=(0.0, 0.5, 0.0, 0.3), tool=FINGERS),
        ArmPlacement(DESC, "right", base=(0.1, -0.5, 0.0, -0.4)))


@pytest.fixture
def world() -> World:
    return World(ARMS, START, scene_xml=default_scene_path())


def hold_where_started(world: World) -> None:
    """Each arm: plain joint impedance about its start (no idle hold, whose standstill would
    put a disturbed joint back exactly)."""
    for name, arm in world.arms.items():
        arm.command(JointCommand.impedance(START[name], K_IDLE, D_IDLE))


def test_two_arms_each_have_their_own_names_and_base():
    world = World(ARMS, START)
    model = world.model
    for name in ("left/hand", "right/hand", "left/finger1", "left/base", "right/base"):
        model.body(name)
    for name in ("hand", "right/finger1"):
        with pytest.raises(KeyError):
            model.body(name)
    assert model.nq == 7 + 2 + 7  # the left arm's fingers, no scene


def test_two_arms_hold_still_to_the_bit(world):
    hold_where_started(world)
    for k in range(500):
        world.step()
        if k % 2:
            world.finish_step()
        for name, arm in world.arms.items():
            measured = arm.measure()
            np.testing.assert_array_equal(measured.q, START[name])
            assert not measured.dq.any() and not measured.tau_ext.any()


@pytest.mark.parametrize("mover, still", [("left", "right"), ("right", "left")])
def test_each_arm_moves_only_under_its_own_command(world, mover, still):
    hold_where_started(world)
    for _ in range(20):
        world.step()
    target = START[mover] + np.array([0.2, -0.1, 0.15, 0.1, -0.2, 0.1, 0.3])
    world.arms[mover].command(JointCommand.impedance(target, K_IDLE, D_IDLE))
    for _ in range(1000):  # (the wrist's motors saturate at 12 Nm: it takes its time)
        world.step()
        resting = world.arms[still].measure()
        np.testing.assert_array_equal(resting.q, START[still])
        assert not resting.dq.any() and not resting.tau_ext.any()
    np.testing.assert_allclose(world.arms[mover].measure().q, target, atol=2e-3)


def test_each_arm_reports_in_its_own_base_frame_as_a_lone_arm_does():
    world = World(ARMS, START)
    for name, arm in world.arms.items():
        lone = MujocoBackend(DESC, START[name])
        measured, alone = arm.measure(), lone.measure()
        np.testing.assert_allclose(measured.O_T_F, alone.O_T_F, atol=1e-12)
        np.testing.assert_allclose(measured.J_F, alone.J_F, atol=1e-12)
        np.testing.assert_allclose(measured.tau_J, alone.tau_J, atol=1e-9)
        np.testing.assert_allclose(measured.accelerometer_top, alone.accelerometer_top,
                                   atol=1e-9)
        q = START[name] + 0.1
        pose, jacobian = arm.queries.flange_pose_and_jacobian(q)
        np.testing.assert_allclose(pose, lone.flange_pose(q), atol=1e-12)
        np.testing.assert_allclose(arm.queries.flange_pose(q), lone.flange_pose(q), atol=1e-12)
        np.testing.assert_allclose(jacobian, lone.jacobian_flange(q), atol=1e-12)
        np.testing.assert_allclose(arm.queries.jacobian_flange(q), lone.jacobian_flange(q),
                                   atol=1e-12)
        np.testing.assert_allclose(arm.queries.gravity(q), lone.gravity(q), atol=1e-9)
        # ... and in the world, the flange is where the base puts it.
        R, p = ARMS[0 if name == "left" else 1].base_frame()
        site = world.model.site(f"{name}/flange").id
        np.testing.assert_allclose(world.data.site_xpos[site], R @ measured.O_T_F[:3, 3] + p,
                                   atol=1e-12)


def test_arms_touch_each_other():
    """Arms standing in each other's way collide (their own neighbouring links still don't)."""
    near = (ArmPlacement(DESC, "a", base=(0.0, 0.0, 0.0, 0.0)),
            ArmPlacement(DESC, "b", base=(0.05, 0.0, 0.0, PI)))
    world = World(near, {"a": HOME, "b": HOME})
    model, data = world.model, world.data
    pairs = set()
    for contact in data.contact[:data.ncon]:
        names = [model.body(model.geom_bodyid[g]).name for g in contact.geom]
        pairs.add(tuple(sorted(n.split("/")[0] for n in names)))
    assert ("a", "b") in pairs and ("a", "a") not in pairs and ("b", "b") not in pairs


def test_a_mujoco_warning_is_a_log_line_not_bare_text(caplog, capfd):
    import mujoco

    from franka_sim.assembly import WorldParts
    from franka_sim.config import Config

    world = WorldParts(Config()).make_physics().world
    world.data.qpos[-7] = 1e20  # the cube flung past what MuJoCo integrates: it resets
    with caplog.at_level("WARNING"):
        mujoco.mj_step(world.model, world.data)
    [line] = [r.getMessage() for r in caplog.records]
    assert line.startswith("MuJoCo: Nan, Inf or huge value in QPOS")
    assert "WARNING: Nan" not in capfd.readouterr().err
