"""Scenes: the packaged world (a table, a cube in reach), `--scene PATH` / FRANKA_SIM_SCENE for
another MJCF, and a scene that cannot be loaded refused on one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pylibfranka
import pytest

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description import hand
from franka_sim.description.kinematics import flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.backend import JointCommand
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.testing import fresh_loopback_address, running_sim

DESC = load_arm_description(default_urdf_text())
READY = np.array(READY_POSE)
TCP_AT_READY = (flange_pose(DESC, READY) @ hand.F_T_NE_HAND)[:3, 3]


def test_default_scene_is_packaged_data():
    path = default_scene_path()
    assert path.is_file() and path.parent.name == "scenes"
    assert path.parent.parent.name == "franka_sim"  # inside the package: the wheel ships it


def test_default_scene_has_a_table_and_a_cube_resting_within_reach():
    backend = MujocoBackend(DESC, READY, scene_xml=default_scene_path(), tool=FINGERS)
    K = np.array([3000, 3000, 3000, 2500, 2500, 2000, 2000.0])
    for _ in range(1000):
        measured = backend.step(JointCommand.impedance(READY, K, 0.02 * K))
    model, data = backend.model, backend.data
    cube = data.body("scene/cube")
    assert cube.xpos == pytest.approx([0.45, 0.0, 0.025], abs=2e-4)  # resting on the tabletop
    assert np.linalg.norm(cube.xpos) < 0.855  # the FR3's reach
    assert model.body("scene/cube").mass[0] == pytest.approx(0.1)
    assert data.tree_asleep[model.body_treeid[model.body("scene/cube").id]] >= 0  # at rest: asleep
    contacts = {frozenset((model.geom(c.geom1).name, model.geom(c.geom2).name))
                for c in data.contact[:data.ncon]}
    assert contacts <= {frozenset(("scene/top", "scene/cube"))}  # the arm touches nothing
    assert np.array_equal(measured.q, READY)  # and holds bit-exactly


POST = f"""<mujoco><worldbody>
  <body name="post" pos="{TCP_AT_READY[0]} {TCP_AT_READY[1]} {TCP_AT_READY[2]}">
    <geom name="post" type="box" size="0.01 0.015 0.01"/>
  </body>
</worldbody></mujoco>"""


def test_scene_flag_puts_its_bodies_around_the_arm(tmp_path):
    """A fixed 3 cm post between the open fingers at the ready pose: only that scene has it."""
    path = tmp_path / "post.xml"
    path.write_text(POST)
    with running_sim("--scene", str(path)) as sim:
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.grasp(0.03, 0.1, 10.0) is True
        assert gripper.read_once().width == pytest.approx(0.03, abs=5e-4)
        assert sim.log_matching(str(path))
    with running_sim() as sim:  # the default scene has nothing there
        assert pylibfranka.Gripper(sim.host).grasp(0.03, 0.1, 10.0) is False


def test_scene_from_the_environment(tmp_path):
    path = tmp_path / "post.xml"
    path.write_text(POST)
    with running_sim(env={"FRANKA_SIM_SCENE": str(path)}) as sim:
        assert sim.log_matching(f"scene {path}")


@pytest.mark.parametrize("text, what", [
    ("<mujoco><worldbody><geom type='box'", "XML parse error"),
    ("<mujoco><worldbody><body name='x'><freejoint/></body></worldbody></mujoco>",
     "mass and inertia"),
    # (MuJoCo takes a NaN with a warning; every cycle of such a world would fail)
    ("<mujoco><worldbody><site name='arm/fr3' pos='nan 0 0'/></worldbody></mujoco>",
     "stands arm fr3 at a pose that is not finite"),
    ("<mujoco><worldbody><body name='b' pos='0.5 nan 0.2'><freejoint/><geom size='0.02'/>"
     "</body></worldbody></mujoco>", "body 'scene/b' is at a pose that is not finite"),
    ("<mujoco><worldbody><body name='b' pos='0.5 0.3 0.2'><freejoint/><geom size='inf'/>"
     "</body></worldbody></mujoco>", "a geom size that is not finite"),
    # (a real arm cannot stand inside a body: its Hand at the ready pose is in this box)
    ("<mujoco><worldbody><body name='slab' pos='0.31 0 0.5'><geom type='box' "
     "size='0.04 0.04 0.04'/></body></worldbody></mujoco>",
     "arm fr3: at its starting pose it would be inside another body: hand into scene/slab"),
])
def test_a_scene_that_cannot_load_is_refused_on_one_line(tmp_path, text, what):
    path = tmp_path / "broken.xml"
    path.write_text(text)
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), "--scene", str(path)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert what in done.stderr and str(path) in done.stderr
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_help_names_the_new_flags_and_their_environment_variables():
    out = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--help"],
                         capture_output=True, text=True, env={"COLUMNS": "200"}, timeout=60).stdout
    for flag, env in [("--scene", "FRANKA_SIM_SCENE"), ("--no-gripper", "FRANKA_SIM_NO_GRIPPER")]:
        assert flag in out and env in out
