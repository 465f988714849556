"""Compile the world: one or several arms (physics/arm_model.py), optionally inside a scene.

The options are the robot's: one physics step per published state, the implicit-fast
integrator, gravity, and sleeping for resting scene objects. A scene (MJCF: a table, objects)
can be attached around the arms; the package ships one (scenes/default.xml).
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from franka_sim.description.urdf import ArmDescription
from franka_sim.footprint import load_plugins
from franka_sim.package_files import PACKAGE_DIR
from franka_sim.physics.arm_model import ROTOR_INERTIA_FR3, add_arm, arm_bits
from franka_sim.physics.tool import ToolMount
from franka_sim.physics.mobile_base import add_mobile_base
from franka_sim.protocol.timing import CYCLE_PERIOD

GRAVITY = (0.0, 0.0, -9.81)
SCENE_PREFIX = "scene/"


@dataclass(frozen=True)
class ArmPlacement:
    """One arm of the world: what it is, its name and where its base stands.

    `name` prefixes every name the arm adds ("left" → "left/flange"); the empty name keeps the
    arm's own names, for a world of one arm. `base` is (x, y, z, yaw) of the arm's root frame
    in the world frame (m, rad); None: the world origin. A base turns about the vertical only,
    so gravity stays along the base's −z, as the robot's model assumes; what the arm reports
    (O_T_F, J_F) is in its base frame, as a robot reports it. An arm that `rides` stands on
    the mobile base (physics/mobile_base.py), `base` giving its mount where the base starts.
    """

    desc: ArmDescription
    name: str = ""
    base: tuple[float, float, float, float] | None = None
    tool: ToolMount | None = None  # a tool's moving parts on the hand body (physics/tool.py)
    armature: tuple[float, ...] = ROTOR_INERTIA_FR3
    rides: bool = False
    # Visual meshes by link (physics/arm_meshes.py, --meshes); None: our own shapes.
    look: dict | None = field(default=None, compare=False, hash=False)

    @property
    def prefix(self) -> str:
        return f"{self.name}/" if self.name else ""

    @property
    def tops(self) -> tuple[str, str]:
        """Its bodies' tops in the world's model: its fixed first link, and the chain from its
        first joint (hand and tool below it)."""
        first = self.desc.joints[0]
        return self.prefix + first.parent, self.prefix + first.child

    def base_frame(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(R, p): the base's rotation and position in the world frame; None at the origin."""
        if self.base is None:
            return None
        x, y, z, yaw = self.base
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array([x, y, z])


def build_world_model(arms: list[ArmPlacement] | tuple[ArmPlacement, ...], *,
                      scene_xml: str | os.PathLike | None = None) -> mujoco.MjModel:
    """Compile the arms, each where its placement says, optionally inside a scene (see
    build_world_spec)."""
    return build_world_spec(arms, scene_xml=scene_xml).compile()


def world_mjcf(arms: list[ArmPlacement] | tuple[ArmPlacement, ...], *,
               scene_xml: str | os.PathLike | None = None) -> str:
    """The world build_world_model compiles, as one MJCF document (for another engine)."""
    spec = build_world_spec(arms, scene_xml=scene_xml)
    spec.compile()
    return spec.to_xml()


def build_world_spec(arms: list[ArmPlacement] | tuple[ArmPlacement, ...], *,
                     scene_xml: str | os.PathLike | None = None) -> mujoco.MjSpec:
    """The arms, each where its placement says, optionally inside a scene, not yet compiled.

    `scene_xml` is an MJCF document (its text, or a path to its file, which lets it refer to
    meshes and includes next to it) whose worldbody contents (floor, table, objects) are
    attached around the arms, with names prefixed "scene/" so they cannot clash with theirs.
    The arms' options (1 ms step, integrator, gravity) win over the scene's.
    """
    if not arms:
        raise ValueError("a world needs at least one arm")
    names = [arm.name for arm in arms]
    if len(set(names)) != len(names) or (len(arms) > 1 and "" in names):
        raise ValueError(f"arms need distinct names (and a name each when several): {names}")
    spec = mujoco.MjSpec()
    spec.modelname = arms[0].desc.name
    spec.compiler.degree = False  # every angle below is in radians
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.balanceinertia = False
    spec.option.timestep = CYCLE_PERIOD
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = GRAVITY
    # Resting scene objects sleep (exactly still until something touches them) rather than
    # trembling at 1e-9 m/s in their contacts: an idle scene is then truly at rest.
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    riders = [arm for arm in arms if arm.rides]
    carrier = None
    if riders:
        carrier = add_mobile_base(spec, min((arm.base or (0, 0, 0, 0))[2] for arm in riders))
    for i, arm in enumerate(arms):
        parent, base = None, arm.base
        if arm.rides:  # a root body of its own on the base, even at the base's origin
            parent, base = carrier, base or (0.0, 0.0, 0.0, 0.0)
        add_arm(spec, arm.desc, prefix=arm.prefix, base=base, armature=arm.armature,
                tool=arm.tool, extra_bits=arm_bits(i, len(arms)), parent=parent, look=arm.look)
    if scene_xml is not None:
        _plugins_for(scene_xml)
        if isinstance(scene_xml, str):
            scene = mujoco.MjSpec.from_string(scene_xml)
        else:
            scene = mujoco.MjSpec.from_file(os.fspath(scene_xml))
        spec.attach(scene, frame=spec.worldbody.add_frame(), prefix=SCENE_PREFIX)
    return spec


def build_model(desc: ArmDescription, *, armature=ROTOR_INERTIA_FR3,
                scene_xml: str | os.PathLike | None = None,
                tool: ToolMount | None = None) -> mujoco.MjModel:
    """Compile one arm at the world origin (its own names), optionally inside a scene."""
    return build_world_model([ArmPlacement(desc, tool=tool, armature=tuple(armature))],
                             scene_xml=scene_xml)


class SceneError(ValueError):
    """An MJCF scene that cannot be loaded or attached around the arms, or arms that cannot
    stand where they are placed."""


MOUNT_PREFIX = "arm/"  # a scene's site "arm/NAME" is where arm NAME's base stands


def packaged_scenes() -> dict[str, Path]:
    """The scenes the package ships, by name ("default", "dual_arm_table", "mobile_duo")."""
    return {path.stem: path for path in (PACKAGE_DIR / "scenes").iterdir()
            if path.name.endswith(".xml")}


# Packaged scenes whose arm sites stand on the mobile base's column (served with --mobile-base).
ON_THE_BASE = ("mobile_duo",)


def stands_arms_on_the_base(path: os.PathLike) -> bool:
    """Whether the scene at `path` is one whose arms stand on the mobile base."""
    packaged = packaged_scenes()
    return any(Path(path) == packaged[name] for name in ON_THE_BASE)


def default_scene_path() -> Path:
    """The packaged world: a table under the arm and a 5 cm cube within reach."""
    return packaged_scenes()["default"]


def _plugins_for(scene: str | os.PathLike) -> None:
    """MuJoCo's plugins loaded before a user's MJCF text or file is read (the serving process
    left them out of its import: footprint.py); a packaged scene uses none."""
    if isinstance(scene, str) or Path(scene) not in packaged_scenes().values():
        load_plugins()


def resolve_scene(scene: str | os.PathLike) -> Path:
    """A packaged scene's name or an MJCF file's path, as a path (SceneError: neither)."""
    packaged = packaged_scenes()
    if isinstance(scene, str) and scene in packaged:
        return packaged[scene]
    path = Path(scene)
    if path.is_file():
        return path
    raise SceneError(f"unknown scene {str(scene)!r}: neither a packaged scene "
                     f"({', '.join(sorted(packaged))}) nor an MJCF file")


def scene_mounts(path: os.PathLike) -> dict[str, tuple[float, float, float, float]]:
    """Where the scene at `path` stands its arms: (x, y, z, yaw) of each `arm/NAME` site of
    its worldbody, by NAME (the yaw of the site's orientation about the vertical)."""
    _plugins_for(path)
    try:
        with _warnings_kept():
            spec = mujoco.MjSpec.from_file(os.fspath(path))
    except ValueError as exc:
        raise SceneError(f"cannot load the scene {path}: {' '.join(str(exc).split())}") from None
    names = [site.name[len(MOUNT_PREFIX):] for site in spec.worldbody.sites
             if site.name.startswith(MOUNT_PREFIX)]
    if not names:
        return {}
    with _warnings_kept():
        model = spec.compile()  # resolves euler, axisangle, zaxis, ... into positions, quats
    placed = {}
    for name in names:
        site = model.site(MOUNT_PREFIX + name)
        x, y, z = (float(v) for v in site.pos)
        w, qx, qy, qz = site.quat
        if not np.isfinite([x, y, z, w, qx, qy, qz]).all():
            raise SceneError(f"the scene {path} stands arm {name} at a pose that is not finite "
                             f"(site {MOUNT_PREFIX}{name}: pos {x:g} {y:g} {z:g})")
        yaw = float(np.arctan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)))
        placed[name] = (x, y, z, yaw)
    return placed


def check_world(arms: list[ArmPlacement], path: os.PathLike | None) -> None:
    """Raise SceneError (one line) unless the arms compile inside the scene at `path`, every
    body at a finite pose (MuJoCo takes a NaN in an MJCF with a warning; every cycle would
    then fail)."""
    try:
        with _warnings_kept():
            model = build_world_model(arms, scene_xml=None if path is None else Path(path))
    except ValueError as exc:  # MuJoCo's parse and compile errors
        message = " ".join(str(exc).split())
        raise SceneError(f"cannot load the scene {path}: {message}") from None
    for body in range(model.nbody):  # (the compiled figures: no data, no forward pass)
        if not (np.isfinite(model.body_pos[body]).all()
                and np.isfinite(model.body_quat[body]).all()):
            raise SceneError(f"cannot load the scene {path}: body {model.body(body).name!r} is "
                             "at a pose that is not finite (a NaN or an infinity in the MJCF?)")
    for name in ("geom_pos", "geom_quat", "geom_size", "site_pos", "body_mass",
                 "body_inertia", "qpos0"):
        if not np.isfinite(getattr(model, name)).all():
            raise SceneError(f"cannot load the scene {path}: a {name.replace('_', ' ')} that "
                             "is not finite (a NaN or an infinity in the MJCF?)")


@contextlib.contextmanager
def _warnings_kept():
    """MuJoCo's warnings while a scene is checked (its "XML contains a 'NaN'" before the one
    line that refuses the scene) are not printed: what they warn of is refused, or harmless."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda _message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)
