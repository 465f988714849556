"""The world's bodies from outside: names, poses, placing a free body, pushes counted in steps,
and a reset that undoes all of it (physics/bodies.py, World)."""

from __future__ import annotations

import numpy as np
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.bodies import Inside, NotFree, UnknownBody
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.robot.settings import DEFAULT_K_THETA

Q0 = np.array(READY_POSE)
HOLD = JointCommand.impedance(Q0, DEFAULT_K_THETA, 2 * np.sqrt(DEFAULT_K_THETA), hold=True)


@pytest.fixture
def world_backend(description):
    return MujocoBackend(description, Q0, scene_xml=default_scene_path(), tool=FINGERS)


def test_names_free_bodies_and_the_names_other_descriptions_use(world_backend):
    bodies = world_backend.world.bodies
    assert {"link1", "link7", "hand", "finger1", "scene/table", "scene/cube"} <= set(bodies.names)
    assert "world" not in bodies.names
    assert [name for name in bodies.names if bodies.is_free(name)] == ["scene/cube"]
    assert bodies.find("fr3_link7") == "link7" and bodies.find("fr3_hand") == "hand"
    assert bodies.find("fer_link7") == bodies.find("panda_link7") == "link7"  # a Panda's
    assert bodies.find("cube") == "scene/cube" and bodies.find("scene/cube") == "scene/cube"
    with pytest.raises(UnknownBody):
        bodies.find("link9")


def test_a_placed_body_is_there_at_rest_and_falls_onto_the_table(world_backend):
    world = world_backend.world
    world.place_body("cube", [0.5, 0.1, 0.2], [0.0, 0.0, 0.0, 2.0])  # normalised
    state = world.body_state("scene/cube")
    np.testing.assert_array_equal(state.position, [0.5, 0.1, 0.2])
    np.testing.assert_array_equal(state.quaternion, [0.0, 0.0, 0.0, 1.0])
    assert not state.linear_velocity.any() and not state.angular_velocity.any() and state.free
    for _ in range(600):
        world_backend.step(HOLD)
    state = world.body_state("cube")
    assert state.position[2] == pytest.approx(0.025, abs=1e-3)  # on the tabletop
    np.testing.assert_allclose(state.position[:2], [0.5, 0.1], atol=1e-3)
    with pytest.raises(NotFree):
        world.place_body("link3", [0.0, 0.0, 1.0])


def test_a_body_placed_inside_another_is_refused_and_the_world_unchanged(world_backend):
    """Into the Hand or the tabletop: refused, naming the deepest overlap; on the tabletop
    (touching it) and between the open fingers it goes."""
    world = world_backend.world
    before = world.data.qpos.copy()
    hand = world.body_state("hand").position
    for position, others in [(hand, {"link7", "hand"}), ([0.45, 0.0, 0.01], {"scene/table"})]:
        with pytest.raises(Inside) as refused:
            world.place_body("cube", position)
        assert refused.value.args[0] == "scene/cube" and refused.value.args[1].other in others
        np.testing.assert_array_equal(world.data.qpos, before)
    world.place_body("cube", [0.3, 0.2, 0.025])
    np.testing.assert_array_equal(world.body_state("cube").position, [0.3, 0.2, 0.025])


def test_a_push_acts_for_exactly_its_steps_and_reads_as_external_torque(world_backend):
    world = world_backend.world
    world_backend.step(HOLD)
    world.push("fr3_hand", [10.0, 0.0, 0.0], [0.0, 0.0, 0.0], 5)
    pushed = [world_backend.step(HOLD).tau_ext.any() for _ in range(8)]
    assert pushed == [True] * 5 + [False] * 3
    assert not world.data.xfrc_applied.any()


def test_a_push_on_a_free_body_gives_what_it_says_and_no_more_than_the_step_integrates(
        world_backend):
    """1 N on the 0.1 kg cube for 0.1 s, lifting it (gravity cancelled): 1 m/s; ten times that
    impulse and more is refused, the world untouched."""
    from franka_sim.physics.bodies import MAX_PUSHED_SPEED, TooViolent

    world = world_backend.world
    world.push("cube", [0.0, 0.0, 0.981 + 1.0], [0.0, 0.0, 0.0], 100)
    for _ in range(100):
        world_backend.step(HOLD)
    assert world.body_state("scene/cube").linear_velocity[2] == pytest.approx(1.0, rel=0.01)
    with pytest.raises(TooViolent, match=f"over the {MAX_PUSHED_SPEED:g} m/s"):
        world.push("cube", [0.0, 0.0, 10.5], [0.0, 0.0, 0.0], 100)
    with pytest.raises(TooViolent, match="would spin scene/cube"):
        world.push("cube", [0.0, 0.0, 0.0], [0.0, 0.0, 0.01], 1000)


def test_a_reset_puts_the_world_back_and_ends_every_push(world_backend):
    world = world_backend.world
    start = world.body_state("cube")
    world.place_body("cube", [0.3, -0.2, 0.4])
    world.push("link7", [0.0, 20.0, 0.0], [0.0, 0.0, 1.0], 1000)
    for _ in range(50):
        world_backend.step(HOLD)
    world_backend.reset(Q0, tool_setting=0.03)
    assert not world.data.xfrc_applied.any()
    np.testing.assert_array_equal(world.body_state("cube").position, start.position)
    m = world_backend.measure()
    np.testing.assert_array_equal(m.q, Q0)
    assert m.tool.width == pytest.approx(0.03) and not m.tau_ext.any()
    for _ in range(20):
        assert not world_backend.step(HOLD).tau_ext.any()
