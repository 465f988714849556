"""The world in the browser: every visible MuJoCo geom as a viser mesh under its body's frame,
the frames moved from a snapshot's positions.

The shapes are made once from the compiled model (its geoms' types, sizes, offsets and
colours), so the page shows exactly what MuJoCo's viewer and `render` draw: the arms' visual
geometry, the Hands, the scene's table and objects. Each frame the web thread recomputes the
bodies' poses from the snapshot's qpos on its own MjData and sends only the bodies that moved,
so a world at rest costs no traffic.
"""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh

from franka_sim.physics.first_view import first_view

VISIBLE_GROUPS = (0, 1, 2)  # MuJoCo's default: group 3 and above (collision) hidden
PLANE_EXTENT = 2.0  # m: half the side of the square an infinite plane is drawn as


# Shapes with edges: shaded per face (a cylinder's vertices are shared by its side and its ends,
# whose averaged normals would smear the edge).
_FLAT = (mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_PLANE)


def _rgb(rgba) -> tuple[int, int, int]:
    return tuple(int(round(255 * float(c))) for c in rgba[:3])


def geom_mesh(model, g: int) -> trimesh.Trimesh | None:
    """The geom's surface in its own frame (None: a type the view does not draw)."""
    kind, size = model.geom_type[g], model.geom_size[g]
    t = mujoco.mjtGeom
    if kind == t.mjGEOM_BOX:
        return trimesh.creation.box(extents=2 * size)
    if kind == t.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == t.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 8])
    if kind == t.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=48)
    if kind == t.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
        return mesh
    if kind == t.mjGEOM_PLANE:
        x = size[0] if size[0] > 0 else PLANE_EXTENT
        y = size[1] if size[1] > 0 else PLANE_EXTENT
        return trimesh.creation.box(extents=(2 * x, 2 * y, 1e-3),
                                    transform=trimesh.transformations.translation_matrix(
                                        (0, 0, -5e-4)))
    if kind == t.mjGEOM_MESH:
        mesh_id = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
        f0, nf = model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
        return trimesh.Trimesh(model.mesh_vert[v0:v0 + nv].copy(),
                               model.mesh_face[f0:f0 + nf].copy(), process=False)
    return None


def geom_color(model, g: int) -> tuple[int, int, int]:
    mat = model.geom_matid[g]
    return _rgb(model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g])


class WorldView:
    """`scene`: a viser SceneApi; `model`: the world's MjModel (only read)."""

    def __init__(self, scene, model) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self._frames: dict[int, object] = {}
        self._poses: dict[int, np.ndarray] = {}
        mujoco.mj_kinematics(model, self.data)
        for g in range(model.ngeom):
            if model.geom_group[g] not in VISIBLE_GROUPS or model.geom_rgba[g][3] == 0:
                continue
            mesh = geom_mesh(model, g)
            if mesh is None:
                continue
            body = int(model.geom_bodyid[g])
            frame = self._frame(scene, body)
            scene.add_mesh_simple(
                f"{frame}/g{g}", np.asarray(mesh.vertices, np.float32),
                np.asarray(mesh.faces, np.uint32), color=geom_color(model, g),
                position=model.geom_pos[g].copy(), wxyz=model.geom_quat[g].copy(),
                flat_shading=bool(model.geom_type[g] in _FLAT))
        self.show(None)

    def camera(self) -> tuple[np.ndarray, np.ndarray]:
        """(position, look_at) of a first view of every arm (physics/first_view.py)."""
        return first_view(self.model, self.data)

    def _frame(self, scene, body: int) -> str:
        name = f"/world/b{body}"
        if body not in self._frames:
            self._frames[body] = scene.add_frame(name, show_axes=False)
        return name

    @property
    def bodies(self) -> list[int]:
        return sorted(self._frames)

    def show(self, snapshot) -> int:
        """Move the frames to the snapshot's positions (None: as the model was built); the
        number of bodies that moved."""
        data = self.data
        if snapshot is not None:
            data.qpos[:] = snapshot.qpos
            data.mocap_pos[:] = snapshot.mocap_pos
            data.mocap_quat[:] = snapshot.mocap_quat
            mujoco.mj_kinematics(self.model, data)
        moved = 0
        for body, handle in self._frames.items():
            pose = np.concatenate((data.xpos[body], data.xquat[body]))
            last = self._poses.get(body)
            if last is not None and np.array_equal(last, pose):
                continue
            self._poses[body] = pose
            handle.position = pose[:3]
            handle.wxyz = pose[3:]
            moved += 1
        return moved
