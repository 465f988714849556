"""How an arm looks: visual geometry, separate from the collision envelopes.

Made by us, procedurally, from the arm's description and the envelopes' own sizing
(arm_model.COLLISION_CAPSULES): white link housings, a dark cap on every joint along its
axis, a dark base plate, and the Franka Hand's white body with its dark flange (its fingers
are the tool's own geoms). Visual geoms touch nothing (contype and conaffinity 0) and weigh
nothing (the compiler takes no inertia from geoms), so the physics is the same bits with or
without them. With `--meshes DIR` an installed franka_description's own visual meshes take
their place (physics/arm_meshes.py; add_mesh_look). They are MuJoCo group 2, which the viewer, `render` and the web view draw; the
collision envelopes are group 3, which all three leave out.
"""

from __future__ import annotations

import mujoco
import numpy as np

VISUAL_GROUP = 2
COLLISION_GROUP = 3
LINK_RGBA = (0.93, 0.93, 0.92, 1.0)  # the housings' white
CAP_RGBA = (0.13, 0.13, 0.14, 1.0)  # the joints' dark caps, the base plate, the flange
# The materials (per arm: names carry its prefix). The white glows a little of its own: lit
# from above, the housings' sides would otherwise render mid grey.
LINK_MATERIAL, CAP_MATERIAL = "fr3_white", "fr3_dark"
_MATERIALS = {LINK_MATERIAL: dict(rgba=LINK_RGBA, emission=0.35, specular=0.4, shininess=0.6),
              CAP_MATERIAL: dict(rgba=CAP_RGBA, emission=0.0, specular=0.3, shininess=0.3)}
CAP_HALF_HEIGHT = 0.016  # m
CAP_OVERHANG = 0.004  # m a cap stands out of its housing
VISUAL = dict(contype=0, conaffinity=0, group=VISUAL_GROUP)

# The Hand's body in the flange frame: a box across the finger direction (45° about z),
# standing on the flange, and the flange's dark disc under it.
HAND_BOX_CENTRE = (0.0, 0.0, 0.031)  # (the housing physics/arm_model.py's capsule envelopes)
HAND_BOX_HALF = (0.1, 0.028, 0.028)
HAND_YAW = np.pi / 4


def add_materials(spec: mujoco.MjSpec, prefix: str) -> None:
    for name, properties in _MATERIALS.items():
        material = spec.add_material(name=prefix + name)
        material.rgba = properties["rgba"]
        material.emission = properties["emission"]
        material.specular = properties["specular"]
        material.shininess = properties["shininess"]


def _point(offset: np.ndarray, p) -> np.ndarray:
    return offset[:3, :3] @ np.asarray(p, float) + offset[:3, 3]


def add_link_look(body: mujoco.MjsBody, link: str, capsules, offset: np.ndarray, prefix: str,
                  joint_axis=None) -> None:
    """The link's white housings (its envelopes' shapes) and, if a joint moves it, that joint's
    dark cap at the link's origin along `joint_axis` (in the body's frame)."""
    for k, (start, end, radius) in enumerate(capsules):
        body.add_geom(name=f"{prefix}{link}_visual{k}", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      fromto=np.concatenate([_point(offset, start), _point(offset, end)]),
                      size=[radius, 0, 0], material=prefix + LINK_MATERIAL, **VISUAL)
    widest = max((radius for _, _, radius in capsules), default=0.05)
    if joint_axis is not None:
        axis = np.asarray(joint_axis, float) / np.linalg.norm(joint_axis)
        centre = offset[:3, 3]
        body.add_geom(name=f"{prefix}{link}_cap", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      fromto=np.concatenate([centre - CAP_HALF_HEIGHT * axis,
                                             centre + CAP_HALF_HEIGHT * axis]),
                      size=[widest + CAP_OVERHANG, 0, 0], material=prefix + CAP_MATERIAL,
                      **VISUAL)
    elif link == "link0":  # the base's plate on the ground
        body.add_geom(name=f"{prefix}{link}_plate", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      pos=_point(offset, (0.0, 0.0, 0.006)), size=[widest + 0.02, 0.006, 0],
                      material=prefix + CAP_MATERIAL, **VISUAL)


def add_hand_look(hand_body: mujoco.MjsBody, prefix: str, hand: str) -> None:
    """The Hand's body and its flange disc, in the flange frame."""
    c, s = np.cos(HAND_YAW / 2), np.sin(HAND_YAW / 2)
    hand_body.add_geom(name=f"{prefix}{hand}_visual0", type=mujoco.mjtGeom.mjGEOM_BOX,
                       pos=HAND_BOX_CENTRE, quat=[c, 0.0, 0.0, s], size=HAND_BOX_HALF,
                       material=prefix + LINK_MATERIAL, **VISUAL)
    hand_body.add_geom(name=f"{prefix}{hand}_flange", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                       pos=[0.0, 0.0, 0.005], size=[0.04, 0.005, 0], material=prefix + CAP_MATERIAL,
                       **VISUAL)


def add_mesh_look(spec: mujoco.MjSpec, body: mujoco.MjsBody, name: str, parts, prefix: str,
                  pos=(0.0, 0.0, 0.0), quat=(1.0, 0.0, 0.0, 0.0)) -> None:
    """`parts` (physics/arm_meshes.py: vertices, faces, rgba) as the visual geoms of `name` on
    `body`, the mesh's frame at `pos`, `quat` in the body's."""
    for k, (vertices, faces, rgba) in enumerate(parts):
        mesh = spec.add_mesh(name=f"{prefix}{name}_visual_mesh{k}")
        mesh.uservert = np.asarray(vertices, float).ravel().tolist()
        mesh.userface = np.asarray(faces, np.int32).ravel().tolist()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # (open surfaces are fine)
        body.add_geom(name=f"{prefix}{name}_visual{k}", type=mujoco.mjtGeom.mjGEOM_MESH,
                      meshname=mesh.name, pos=list(pos), quat=list(quat), rgba=list(rgba),
                      **VISUAL)
