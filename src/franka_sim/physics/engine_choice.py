"""The physics engines by name, whether one can run here, and the world built on the one chosen:
what `serve --physics` and the Config rules ask before anything imports numpy, MuJoCo or an
engine (each engine is imported when its world is made; docs/engines.md)."""

from __future__ import annotations

ENGINES = ("mujoco", "genesis")  # the first is the default


def engine_missing(engine: str) -> str | None:
    """One line saying what to install for `engine`; None if it can run here."""
    if engine == "genesis":
        from franka_sim.physics.genesis.runtime import genesis_missing

        return genesis_missing()
    return None


def make_physics(placements, q0s, scene, *, mobile_base: bool = False,
                 engine: str = "mujoco", names=None):
    """The world of `placements` (physics/scene.py) in `scene` on `engine`, each arm's body in
    it by index, then the mobile base's body if the arms ride one (physics/engine.py Physics).
    `names`: the arms' names, as the server calls them (SceneError's lines)."""
    if engine == "genesis":
        from franka_sim.physics.genesis import make_physics as make
    elif engine == "mujoco":
        from franka_sim.physics.mujoco_engine import make_physics as make
    else:
        raise ValueError(f"unknown physics engine {engine!r} (one of {', '.join(ENGINES)})")
    physics = make(placements, q0s, scene, mobile_base=mobile_base)
    _refuse_intrusions(physics.world, placements, q0s, scene, names)
    return physics


def _refuse_intrusions(world, placements, q0s, scene, names=None) -> None:
    """SceneError if an arm starts inside another (their bases too close) or inside a body
    of the scene (its starting pose): a real arm cannot stand there."""
    from franka_sim.physics.scene import SceneError

    for a, b in world.touching_arms():
        raise SceneError(f"arm {a}: placed into arm {b} (their bodies intersect at the "
                         "starting pose; move their bases apart)")
    for i, placement in enumerate(placements):
        if inside := world.intrusions(placement.name, q0s[placement.name]):
            name = names[i] if names else placement.name
            raise SceneError(f"{f'arm {name}' if name else 'the arm'}: at its starting pose it "
                             "would be inside another body: " + "; ".join(map(str, inside[:3]))
                             + (f" (scene {scene})" if scene is not None else "")
                             + "; stand it elsewhere (--arm NAME=ADDRESS@x,y,z, or at an arm/NAME "
                             "site of the scene)")
