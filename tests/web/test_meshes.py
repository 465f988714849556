"""`--meshes DIR`: the arms drawn with a franka_description's visual meshes. The meshes here
are made by the test (trimesh boxes in franka_description's layout), nothing is fetched: each
lands on its link, in group 2, touching nothing, our own shapes gone for it; a folder without
them is refused, saying which mesh is missing."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.assembly import WorldParts
from franka_sim.config import Config
from franka_sim.physics.arm_look import VISUAL_GROUP
from franka_sim.testing import fresh_loopback_address
from support.rendering import render_frame

trimesh = pytest.importorskip("trimesh", reason="--meshes needs trimesh (franka-sim[web])")

LINKS = [f"link{i}" for i in range(8)]


def description(root, links=LINKS, suffix=".stl"):
    """A franka_description's meshes folder: box k of link k, 1 cm + k mm, off its origin."""
    folder = root / "meshes" / "robot_arms" / "fr3" / "visual"
    folder.mkdir(parents=True)
    for k, link in enumerate(links):
        box = trimesh.creation.box(extents=(0.01 + k * 0.001,) * 3)
        box.apply_translation((0.05, 0.0, 0.0))
        box.export(folder / f"{link}{suffix}")
    hand = root / "meshes" / "robot_ee" / "franka_hand_white" / "visual"
    hand.mkdir(parents=True)
    trimesh.creation.box(extents=(0.2, 0.05, 0.08)).export(hand / "hand.obj")
    return root


def test_each_link_is_drawn_with_its_mesh_where_the_mesh_puts_it(tmp_path):
    import mujoco

    physics = WorldParts(Config(meshes=description(tmp_path))).make_physics()
    model, data = physics.world.model, physics.world.data
    mujoco.mj_forward(model, data)
    for k, link in enumerate(LINKS):
        geom = model.geom(f"{link}_visual0")
        assert model.geom_type[geom.id] == mujoco.mjtGeom.mjGEOM_MESH
        assert model.geom_group[geom.id] == VISUAL_GROUP
        assert model.geom_contype[geom.id] == model.geom_conaffinity[geom.id] == 0
        assert model.body(model.geom_bodyid[geom.id]).name == link
        # The box's centre, 5 cm along the link's x axis, wherever the arm stands.
        body = model.geom_bodyid[geom.id]
        expected = data.xpos[body] + data.xmat[body].reshape(3, 3) @ (0.05, 0.0, 0.0)
        assert np.allclose(data.geom_xpos[geom.id], expected, atol=1e-6), link
        size = 0.01 + k * 0.001
        mesh = model.geom_dataid[geom.id]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        extent = np.ptp(model.mesh_vert[start:start + count], axis=0)
        assert np.allclose(extent, size, atol=1e-6)
        assert f"{link}_cap" not in {model.geom(g).name for g in range(model.ngeom)}
    assert model.geom_type[model.geom("hand_visual0").id] == mujoco.mjtGeom.mjGEOM_MESH


def test_the_physics_is_the_same_with_the_meshes(tmp_path):
    import mujoco

    ours = WorldParts(Config()).make_physics().world
    theirs = WorldParts(Config(meshes=description(tmp_path))).make_physics().world
    for name in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "dof_armature"):
        assert np.array_equal(getattr(ours.model, name), getattr(theirs.model, name)), name
    for world in (ours, theirs):  # the arm falling limp for 200 ms, every contact included
        world.data.ctrl[:] = 0.0
        for _ in range(200):
            mujoco.mj_step(world.model, world.data)
    assert np.array_equal(ours.data.qpos, theirs.data.qpos)
    assert np.array_equal(ours.data.qvel, theirs.data.qvel)


def test_a_folder_without_the_meshes_is_refused_saying_which_is_missing(tmp_path):
    root = description(tmp_path, links=LINKS[:5])
    done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host",
                           fresh_loopback_address(), "--meshes", str(root)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    said = " ".join(re.sub("[│╭╮╰╯─]", " ", done.stderr).split())  # (typer's box)
    assert "--meshes" in said and "no visual mesh of the fr3's link5" in said, said
    assert "Traceback" not in done.stderr


def test_render_draws_a_recording_with_the_meshes(tmp_path):
    """A frame of a committed recording rendered with the meshes shows them, not our shapes."""
    recording = (Path(__file__).resolve().parents[1] / "data" / "older_libfranka" / "0.13.6"
                 / "generate_joint_position_motion.mcap")
    _, geom, names, _ = render_frame(recording, tmp_path, fps=1.0, which=0.0,
                                     meshes=description(tmp_path / "description"))
    shown = {names[g] for g in set(np.unique(geom)) - {-1}}
    assert "hand_visual0" in shown
    assert any(n.startswith("link") and "_visual" in n for n in shown)
    assert not any(n.endswith("_cap") for n in shown)
