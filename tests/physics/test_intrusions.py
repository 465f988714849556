"""What an arm put at a pose would be inside (physics/intrusions.py): found on data of its
own, the world untouched; refused at start (serve) as at a reset (the control API's tests)."""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.engine_choice import make_physics
from franka_sim.physics.fingers import FINGERS
from franka_sim.physics.scene import ArmPlacement, SceneError, default_scene_path
from franka_sim.physics.world import World

DESC = load_arm_description(default_urdf_text())
INTO_THE_TABLE = np.array([0.0, 1.6, 0.0, -0.3, 0.0, 1.9, 0.78])


def _world(*placements: ArmPlacement) -> World:
    return World(placements, {p.name: np.array(READY_POSE) for p in placements},
                 scene_xml=default_scene_path())


def test_the_hand_reaching_through_the_table_is_inside_it_and_nothing_moves():
    world = _world(ArmPlacement(DESC, tool=FINGERS))
    qpos = world.data.qpos.copy()
    found = world.intrusions("", INTO_THE_TABLE)
    assert {(i.arm_body, i.other) for i in found} == {("finger1", "scene/table"),
                                                      ("finger2", "scene/table")}
    assert all(0.02 < i.depth < 0.05 for i in found)
    assert str(found[0]).startswith("finger") and "into scene/table (" in str(found[0])
    np.testing.assert_array_equal(world.data.qpos, qpos)  # the world was not touched
    assert world.intrusions("", np.array(READY_POSE)) == []  # the cube and table: not the arm's


FOLDED = np.array([0.0, -1.7, 0.0, -3.0, 0.0, 0.6, 0.0])  # within every joint's range


def test_an_arm_folded_into_itself_is_inside_its_own_link():
    """Each joint in its range, yet the hand would be inside link 2: the engine's contact
    between the two would hold the arm off that pose (tau_J at its limit) rather than rest."""
    world = _world(ArmPlacement(DESC, tool=FINGERS))
    found = world.intrusions("", FOLDED)
    assert {(i.arm_body, i.other) for i in found} == {("link2", "hand")}
    assert found[0].depth > 0.03


def test_the_fingers_are_where_the_reset_puts_them():
    """Over the cube, the Hand open (as a reset leaves it) is clear of it; closed to 1 cm
    (a reset's `gripper_width`) its fingers would be inside it."""
    world = _world(ArmPlacement(DESC, tool=FINGERS))
    over_the_cube = np.array([0.0, 0.3503, 0.0, -2.5381, 0.0, 2.8884, 0.7854])
    assert world.intrusions("", over_the_cube) == []
    closed = world.intrusions("", over_the_cube, 0.01)
    assert {(i.arm_body, i.other) for i in closed} == {("finger1", "scene/cube"),
                                                       ("finger2", "scene/cube")}


def test_in_a_world_of_two_arms_the_other_arm_is_where_it_stands():
    left = ArmPlacement(DESC, name="left", base=(0.0, 0.3, 0.0, 0.0), tool=FINGERS)
    right = ArmPlacement(DESC, name="right", base=(0.0, -0.3, 0.0, 0.0), tool=FINGERS)
    world = _world(left, right)
    towards_right = np.array([-1.57, 0.3, 0.0, -1.2, 0.0, 1.9, 0.78])
    found = world.intrusions("left", towards_right)
    assert found and all(i.arm_body.startswith("left/") and i.other.startswith("right/")
                         for i in found)


def test_an_arm_that_would_start_inside_the_table_is_refused_by_name():
    placement = ArmPlacement(DESC, tool=FINGERS)
    with pytest.raises(SceneError, match=r"the arm: at its starting pose it would be inside "
                                         r"another body: finger\d into scene/table"):
        make_physics([placement], {"": INTO_THE_TABLE}, default_scene_path())


def test_an_arm_on_the_mobile_base_is_checked_where_the_base_drove():
    import mujoco

    from franka_sim.assembly import WorldParts
    from franka_sim.config import ArmSpec, Config

    config = Config(scene="mobile_duo", arms=(ArmSpec("left", "127.0.0.2"),
                                              ArmSpec("right", "127.0.0.3")),
                    mobile_base="127.0.0.4")
    world = WorldParts(config).make_physics().world
    towards_the_table = np.array([-1.571, 1.6, 0.0, -0.9, 0.0, 2.5, 0.78])
    assert world.intrusions("left", towards_the_table) == []  # at the start: clear of it
    world.data.mocap_pos[0][:2] = (0.9, 0.0)  # the base drove 0.9 m ahead, to the table
    mujoco.mj_forward(world.model, world.data)
    found = world.intrusions("left", towards_the_table)
    assert ("left/hand", "scene/table") in {(i.arm_body, i.other) for i in found}
