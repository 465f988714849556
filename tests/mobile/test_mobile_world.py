"""The arms ride the mobile base: its body is put where the base's core says, the arms go along,
each still reads its flange in its own base frame, and a world whose base has stopped comes to
rest exactly as a fixed one does."""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mobile_base import BaseBody
from franka_sim.physics.mujoco_backend import ArmBackend
from franka_sim.physics.scene import ArmPlacement, resolve_scene, scene_mounts
from franka_sim.physics.world import World

DESC = load_arm_description(default_urdf_text())
K = np.array([600.0, 600, 600, 600, 250, 150, 50])


@pytest.fixture
def duo():
    scene = resolve_scene("mobile_duo")
    mounts = scene_mounts(scene)
    placements = [ArmPlacement(DESC, name, base=mounts[name], tool=FINGERS, rides=True)
                  for name in ("left", "right")]
    world = World(placements, {p.name: np.array(READY_POSE) for p in placements},
                  scene_xml=scene)
    arms = [ArmBackend(world, p.name) for p in placements]
    hold = JointCommand.impedance(np.array(READY_POSE), K, 2 * np.sqrt(K), hold=True)
    for arm in arms:
        arm.command(hold)
    return world, arms, BaseBody(world.model, world.data)


def test_the_scene_stands_the_arms_on_the_column_facing_sideways():
    mounts = scene_mounts(resolve_scene("mobile_duo"))
    assert mounts["left"] == pytest.approx((0.0, 0.35, 0.9, np.pi / 2))
    assert mounts["right"] == pytest.approx((0.0, -0.35, 0.9, -np.pi / 2))


def test_the_arms_ride_the_base_and_read_in_their_own_base_frame(duo):
    world, arms, base = duo
    flange = world.model.site("left/flange").id
    start_reading = arms[0].measure().O_T_F.copy()
    start_world = world.data.site_xpos[flange].copy()
    for k in range(1000):
        base.command(0.3e-3 * k, 0.1e-3 * k, 0.5e-3 * k)  # 0.3 m, 0.1 m, 0.5 rad in 1 s
        world.step()
    for arm in arms:
        assert np.array_equal(arm.measure().q, np.array(READY_POSE))  # not a tremble
    np.testing.assert_allclose(arms[0].measure().O_T_F, start_reading, atol=1e-14)
    # In the world the flange went with the base: turned 0.5 rad about the base's origin.
    c, s = np.cos(0.4995), np.sin(0.4995)
    expected = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ start_world
    np.testing.assert_allclose(world.data.site_xpos[flange],
                               expected + [0.2997, 0.0999, 0.0], atol=1e-9)


def test_a_base_that_stopped_leaves_a_world_at_rest(duo):
    world, arms, base = duo
    for k in range(300):
        base.command(0.0, 0.0, 1e-3 * k)
        world.step()
    measured = arms[0].measure()
    for _ in range(5):
        world.step()
    # Steps that change nothing are not recomputed: the same measurement comes back.
    assert arms[0].measure() is not measured
    settled = arms[0].measure()
    world.step()
    assert arms[0].measure() is settled
    assert np.array_equal(settled.q, np.array(READY_POSE))
