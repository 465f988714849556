"""`serve --meshes DIR`: the arms' visual geometry from an installed franka_description's own
visual meshes (its ROS package: links link0-link7 and the Hand), in place of our procedural
shapes (physics/arm_look.py). Nothing is shipped or fetched: the files are the user's.

The meshes are read with trimesh (the `web` extra; Collada `.dae`, the format
franka_description ships its visual meshes in, also needs pycollada), each coloured part
becoming one visual geom of the link (group 2, touching and weighing nothing). The link frames
are the URDF's, which the description's meshes are drawn in; the Hand's mesh is in its own
frame, turned -45° about z from the flange as franka_description mounts it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

ARM_LINKS = tuple(f"link{i}" for i in range(8))
HAND_MESH = "hand"
HAND_YAW = -np.pi / 4  # the hand frame from the flange (franka_description's hand joint)
# Where a franka_description keeps a link's visual mesh (newer and older layouts), by robot.
_ROBOT_FOLDERS = {"fr3": ("fr3",), "fer": ("fer", "panda")}
_ARM_LAYOUTS = ("meshes/robot_arms/{robot}/visual/{name}", "meshes/visual/{name}")
_HAND_LAYOUTS = ("meshes/robot_ee/franka_hand_white/visual/{name}", "meshes/visual/{name}")
_SUFFIXES = (".dae", ".obj", ".stl", ".glb")
_DEFAULT_RGBA = (0.93, 0.93, 0.92, 1.0)

Part = tuple[np.ndarray, np.ndarray, tuple[float, float, float, float]]  # vertices, faces, rgba


class MeshError(ValueError):
    """A meshes folder that cannot be used; the message says why, on one line."""


def find_meshes(root: str | os.PathLike, robot: str) -> dict[str, Path]:
    """The visual mesh file of each arm link (and of the Hand, when there is one) under
    `root` for `robot` (MeshError: a link without one)."""
    root = Path(root)
    found: dict[str, Path] = {}
    folders = _ROBOT_FOLDERS.get(robot, (robot,))
    for link in ARM_LINKS:
        candidates = [root / layout.format(robot=folder, name=link) for layout in _ARM_LAYOUTS
                      for folder in folders]
        path = _first(candidates)
        if path is None:
            suffixes = ",".join(suffix[1:] for suffix in _SUFFIXES)
            looked = f"{_ARM_LAYOUTS[0].format(robot=folders[0], name=link)}.{{{suffixes}}}"
            raise MeshError(f"{root}: no visual mesh of the {robot}'s {link} (looked for "
                            f"{looked} and the older meshes/visual/{link}.*)")
        found[link] = path
    hand = _first([root / layout.format(name=HAND_MESH) for layout in _HAND_LAYOUTS])
    if hand is not None:
        found[HAND_MESH] = hand
    return found


def _first(candidates: list[Path]) -> Path | None:
    for stem in candidates:
        for suffix in _SUFFIXES:
            if stem.with_suffix(suffix).is_file():
                return stem.with_suffix(suffix)
    return None


def load_parts(path: Path) -> tuple[Part, ...]:
    """The mesh's coloured parts, in the file's frame (MeshError: unreadable)."""
    try:
        import trimesh
    except ImportError:
        raise MeshError("--meshes needs trimesh: pip install 'franka-sim[web]'") from None
    try:
        scene = trimesh.load(str(path), force="scene")
    except ImportError as exc:  # a format's reader missing (pycollada for .dae)
        raise MeshError(f"{path.name}: {exc} (Collada needs pycollada: pip install pycollada)") \
            from None
    except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds: one line
        raise MeshError(f"{path}: cannot read it ({type(exc).__name__}: {exc})") from None
    parts = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        mesh = scene.geometry[name]
        if len(mesh.faces) == 0:
            continue
        vertices = trimesh.transform_points(mesh.vertices, transform)
        parts.append((np.asarray(vertices, np.float64), np.asarray(mesh.faces, np.int32),
                      _colour(mesh)))
    if not parts:
        raise MeshError(f"{path}: no triangles in it")
    return tuple(parts)


def _colour(mesh) -> tuple[float, float, float, float]:
    visual = getattr(mesh, "visual", None)
    material = getattr(visual, "material", None)
    colour = getattr(material, "main_color", None)
    if colour is None and getattr(visual, "kind", None) == "face":
        colour = np.median(visual.face_colors, axis=0)
    if colour is None:
        return _DEFAULT_RGBA
    rgba = np.asarray(colour, float) / 255.0
    return tuple(float(c) for c in rgba[:3]) + (1.0,)


def load_look(root: str | os.PathLike, robot: str) -> dict[str, tuple[Part, ...]]:
    """Every link's parts (and the Hand's), read once for all arms of that kind."""
    return {link: load_parts(path) for link, path in find_meshes(root, robot).items()}
