"""The suction cup in the physics (physics/suction.py): it seals on a flat face it covers and
nothing else, the arm carries what it holds, and it lets go of a part that asks more than the
vacuum gives, or when vented."""

from __future__ import annotations


import numpy as np
import pytest

from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics import suction as sc
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path

import pick_and_place as pp

DESC = load_arm_description(default_urdf_text())
K = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
D = np.array([60, 60, 50, 50, 30, 25, 15.0])
AT = pp.solve_ik(pp.CUBE + [0, 0, 0.024], pp.READY)  # the lip 1 mm into the cube's top
ABOVE = pp.solve_ik(pp.CUBE + [0, 0, 0.175], AT)
SPHERE = """<mujoco><worldbody>
  <geom name="top" type="box" pos="0.25 0 -0.02" size="0.6 0.6 0.02"/>
  <body name="ball" pos="0.45 0 0.025"><freejoint/><geom type="sphere" size="0.025" mass="0.1"/>
  </body></worldbody></mujoco>"""


def cup_on_cube(mass=None, scene=None, tmp_path=None):
    if scene is not None:
        path = tmp_path / "scene.xml"
        path.write_text(scene)
        scene = path
    backend = MujocoBackend(DESC, AT, scene_xml=scene or default_scene_path(), tool=sc.CUP)
    if mass is not None:
        backend.model.body_mass[backend.model.body("scene/cube").id] = mass
    return backend


def hold(backend, q, command=None, steps=1):
    for _ in range(steps):
        measured = backend.step(JointCommand.impedance(q, K, D), command)
    return measured


def lift(backend, seconds, to=ABOVE):
    n = int(seconds * 1000)
    for i in range(n + 500):
        s = min(1.0, i / n)
        measured = hold(backend, AT + (3 * s * s - 2 * s ** 3) * (to - AT))
    return measured


def position(backend, name="scene/cube"):
    return backend.data.xpos[backend.model.body(name).id].copy()


def test_it_seals_on_the_cube_draws_its_vacuum_and_lifts_it():
    backend = cup_on_cube()
    cup = hold(backend, AT, sc.SuctionCommand(500.0)).tool
    assert cup.sealed and cup.part == "scene/cube" and cup.pumping
    cup = hold(backend, AT, steps=400).tool
    # 2500 mbar/s: 500 mbar in 200 steps, then the pump idles
    assert cup.vacuum == 500.0 and not cup.pumping
    cup = lift(backend, 2.0).tool
    assert cup.sealed and position(backend)[2] > 0.16


def test_the_arm_carries_the_held_part_as_external_torque():
    backend = cup_on_cube(mass=0.5)
    hold(backend, AT, sc.SuctionCommand(750.0), steps=400)
    measured = lift(backend, 2.0)
    J = backend.jacobian_flange(measured.q)  # (6, 7): the lip and the part lie on its axis
    weight = np.array([0, 0, -0.5 * 9.81, 0, 0, 0])
    # the robot's external torque is what it exerts on the part: holding up its weight
    expected = -J[:3].T @ weight[:3]
    assert np.linalg.norm(measured.tau_ext - expected) < 0.05 * np.linalg.norm(expected)
    released = hold(backend, ABOVE, sc.SuctionCommand(vent=True), steps=1000)
    assert np.linalg.norm(released.tau_ext) < 1e-6  # the part gone, the arm bears nothing


def test_no_seal_without_the_pump_or_on_a_round_part(tmp_path):
    backend = cup_on_cube()
    assert not hold(backend, AT, sc.SuctionCommand(), steps=50).tool.sealed
    ball = cup_on_cube(scene=SPHERE, tmp_path=tmp_path)
    cup = hold(ball, AT, sc.SuctionCommand(500.0), steps=200).tool
    assert not cup.sealed and cup.vacuum == 0.0 and cup.pumping


def test_a_part_heavier_than_the_vacuum_holds_is_pulled_off_and_falls():
    backend = cup_on_cube(mass=3.0)  # 29 N against 23.6 N at the pump's most
    assert hold(backend, AT, sc.SuctionCommand(750.0), steps=400).tool.vacuum == 750.0
    cup = lift(backend, 2.0).tool
    assert not cup.sealed and cup.lost.startswith("pulled off")
    assert position(backend)[2] == pytest.approx(0.025, abs=0.002)  # on the table


def test_venting_lets_go():
    backend = cup_on_cube()
    hold(backend, AT, sc.SuctionCommand(750.0), steps=400)
    lift(backend, 1.0)
    cup = hold(backend, ABOVE, sc.SuctionCommand(vent=True), steps=100).tool
    assert cup.sealed and cup.vacuum == pytest.approx(250.0)  # 5000 mbar/s
    cup = hold(backend, ABOVE, steps=50).tool
    # the 0.1 kg cube falls once 4.2 mbar no longer hold its 0.98 N, a step before ambient
    assert not cup.sealed and cup.lost.startswith("pulled off")
    hold(backend, ABOVE, steps=1000)
    assert position(backend)[2] == pytest.approx(0.025, abs=0.002)


def test_a_reset_lets_go_and_idles():
    backend = cup_on_cube()
    hold(backend, AT, sc.SuctionCommand(750.0), steps=400)
    backend.reset(AT)
    cup = backend.measure().tool
    assert not cup.sealed and cup.vacuum == 0.0 and not backend.data.eq_active.any()


def test_a_held_part_placed_elsewhere_leaves_the_cup_and_stays_there():
    """Placed through the control API while sealed on: the seal goes (as when a hand pulls a
    part off a cup), not a weld that pulls the part back under the cup."""
    backend = cup_on_cube()
    hold(backend, AT, sc.SuctionCommand(750.0), steps=400)
    lift(backend, 1.0)
    backend.world.place_body("scene/cube", [0.3, 0.2, 0.025])
    cup = hold(backend, ABOVE, steps=500).tool
    assert not cup.sealed and cup.part is None and cup.vacuum == 0.0
    assert cup.lost == "placed elsewhere"
    np.testing.assert_allclose(position(backend)[:2], [0.3, 0.2], atol=1e-3)
