"""The recording's configuration record: what replay needs to build the same robot again."""

from __future__ import annotations

import hashlib
import json
import tempfile
from pathlib import Path

from franka_sim.config import DEFAULT_ARM, ArmSpec, ClockMode, Config
from franka_sim.recording import FORMAT_VERSION

_FLAGS = ("enforce_comm_constraints", "enforce_motion_limits", "joint_discontinuity_scale",
          "gripper")


def sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def describe(config: Config, urdf_text: str, scene: Path) -> dict:
    """The metadata of a recording of a robot built from `config`."""
    import franka_sim

    scene_text = Path(scene).read_text()
    spec = config.arm_specs()[0]
    return {
        "franka_sim_version": franka_sim.__version__,
        "arm": spec.name,
        "base": None if spec.base is None else list(spec.base),
        "clock": config.clock.value,
        "q0": list(config.q0),
        "flags": {name: getattr(config, name) for name in _FLAGS},
        "urdf_sha256": sha256(urdf_text),
        "urdf": urdf_text if config.urdf is not None else "",  # the packaged one: its hash
        "scene_name": str(scene),
        "scene_sha256": sha256(scene_text),
        "scene": scene_text,
    }


class Incompatible(Exception):
    """The recording cannot be replayed by this franka-sim (the message says why)."""


def replay_config(meta: dict, workdir: str | None = None) -> Config:
    """A Config that builds the recorded robot (a custom URDF or scene is written to a
    temporary file when its recorded path is gone or changed)."""
    version = int(meta.get("format_version", "0"))
    if version != FORMAT_VERSION:
        raise Incompatible(f"recording format v{version}, this franka-sim reads "
                           f"v{FORMAT_VERSION}")
    flags = json.loads(meta["flags"])
    config = Config(clock=ClockMode(meta["clock"]), q0=tuple(json.loads(meta["q0"])), **flags)
    base = json.loads(meta.get("base", "null"))
    config.arms = (ArmSpec(meta.get("arm", DEFAULT_ARM), config.host,
                           None if base is None else tuple(base)),)
    workdir = workdir or tempfile.mkdtemp(prefix="franka-sim-replay-")
    if meta["urdf"]:
        path = Path(workdir, "robot.urdf")
        path.write_text(meta["urdf"])
        config.urdf = path
    else:
        from franka_sim.description.urdf import default_urdf_text

        if sha256(default_urdf_text()) != meta["urdf_sha256"]:
            raise Incompatible("recorded with another packaged URDF (its sha256 differs)")
    scene = Path(meta["scene_name"])
    if not (scene.is_file() and sha256(scene.read_text()) == meta["scene_sha256"]):
        # Beside nothing it included: a scene that includes files must be found where it was.
        scene = Path(workdir, scene.name or "scene.xml")
        scene.write_text(meta["scene"])
    config.scene = scene
    return config
