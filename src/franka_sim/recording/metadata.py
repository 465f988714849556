"""The recording's configuration record: what replay needs to build the same world again.

A world is its robots (each arm's name and base, and whether a mobile base carries them), the
clock, the start pose, the flags that change a robot's behaviour, the served description and the
scene (their text when they are not the packaged ones). Addresses are not recorded: replay
serves nothing.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from franka_sim.config import ArmSpec, ClockMode, Config
from franka_sim.recording import FORMAT_VERSION

START_FRESH, START_RESET = "fresh", "reset"  # `start`: from a fresh world, or from a reset
_FLAGS = ("enforce_comm_constraints", "enforce_motion_limits", "joint_discontinuity_scale",
          "tool", "robot", "strict_versions", "desk_boot")


def sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def describe(config: Config, urdf_text: str, scene: Path, robots) -> dict:
    """The metadata of a recording of the world built from `config`; `robots`: its parts
    (assembly.py), in the world's order."""
    import franka_sim
    from franka_sim.recording.numerics import numerics

    scene_text = Path(scene).read_text()
    return {
        "franka_sim_version": franka_sim.__version__,
        "numerics": numerics(),  # (replay says so when its kernels differ: numerics.py)
        "robots": [{"name": robot.name, "kind": robot.kind,
                    "base": None if getattr(robot, "spec", None) is None
                    or robot.spec.base is None else list(robot.spec.base),
                    "robot": None if getattr(robot, "spec", None) is None
                    else robot.spec.robot,
                    "tool": None if getattr(robot, "spec", None) is None
                    else robot.spec.tool}
                   for robot in robots],
        "clock": config.clock.value,
        "q0": list(config.q0),
        "flags": {name: getattr(config, name) for name in _FLAGS},
        "urdf_sha256": sha256(urdf_text),
        "urdf": urdf_text if config.urdf is not None else "",  # the packaged one: its hash
        "scene_name": str(scene),
        "scene_sha256": sha256(scene_text),
        "scene": scene_text,
        "start": START_FRESH,
    }


class Incompatible(Exception):
    """The recording cannot be replayed by this franka-sim (the message says why)."""


_TEXTS = ("urdf", "urdf_sha256", "scene_name", "scene_sha256", "scene", "start")


def damage(meta: dict) -> str | None:
    """What is wrong with a recording's metadata (fields as `describe` writes them, JSON where
    not text); None: nothing a reader or replay would trip on."""
    missing = [key for key in ("robots", "clock", "q0", "flags", *_TEXTS) if key not in meta]
    if missing:
        return f"no {', '.join(missing)}"
    parsed = {}
    for key in ("robots", "q0", "flags"):
        try:
            parsed[key] = json.loads(meta[key])
        except ValueError:
            return f"{key} {meta[key][:80]!r} is not JSON"
    robots, q0, flags = parsed["robots"], parsed["q0"], parsed["flags"]
    if not (isinstance(robots, list) and robots and all(
            isinstance(r, dict) and isinstance(r.get("name"), str)
            and r.get("kind") in ("arm", "base") for r in robots)):
        return f"robots {meta['robots'][:80]!r} is not a list of named arms and bases"
    if meta["clock"] not in {mode.value for mode in ClockMode}:
        return f"clock {meta['clock'][:40]!r} is not a clock"
    if not (isinstance(q0, list) and len(q0) == 7
            and all(isinstance(v, (int, float)) for v in q0)):
        return f"q0 {meta['q0'][:80]!r} is not 7 joint angles"
    if not isinstance(flags, dict) or set(flags) - set(_FLAGS):
        return f"flags {meta['flags'][:80]!r} are not this franka-sim's"
    return None


def robot_names(meta: dict) -> list[str]:
    """The recorded robots' names, in the world's order (their channels' prefixes)."""
    return [robot["name"] for robot in json.loads(meta["robots"])]


def replay_config(meta: dict, workdir: str) -> Config:
    """A Config that builds the recorded world (a custom URDF or scene is written into
    workdir, which the caller owns and removes, when its recorded path is gone or changed)."""
    version = int(meta.get("format_version", "0"))
    if version != FORMAT_VERSION:
        raise Incompatible(f"recording format v{version}, this franka-sim reads "
                           f"v{FORMAT_VERSION}")
    flags = json.loads(meta["flags"])
    config = Config(clock=ClockMode(meta["clock"]), q0=tuple(json.loads(meta["q0"])), **flags)
    robots = json.loads(meta["robots"])
    # Addresses only tell robots apart here: replay opens no socket.
    config.arms = tuple(ArmSpec(robot["name"], f"replay-{i}",
                                None if robot["base"] is None else tuple(robot["base"]),
                                robot.get("robot"), robot.get("tool"))
                        for i, robot in enumerate(robots) if robot["kind"] == "arm")
    if any(robot["kind"] == "base" for robot in robots):
        config.mobile_base = "replay-base"
    if meta["urdf"]:
        path = Path(workdir, "robot.urdf")
        path.write_text(meta["urdf"])
        config.urdf = path
    else:
        from franka_sim.description.urdf import default_urdf_text

        first = config.robot_of(config.arm_specs()[0])  # the arm the hash is of
        if sha256(default_urdf_text(first)) != meta["urdf_sha256"]:
            raise Incompatible("recorded with another packaged URDF (its sha256 differs)")
    scene = Path(meta["scene_name"])
    if not (scene.is_file() and sha256(scene.read_text()) == meta["scene_sha256"]):
        # Beside nothing it included: a scene that includes files must be found where it was.
        scene = Path(workdir, scene.name or "scene.xml")
        scene.write_text(meta["scene"])
    config.scene = scene
    return config
