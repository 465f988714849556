"""The Genesis engine (the `genesis` extra): the World and ArmBody protocols of
physics/engine.py on Genesis's rigid solver, for one arm with the Hand (or no tool) in a scene.

runtime.py: whether Genesis is installed, its initialisation; dynamics.py: M, g, c and the
flange at any q from Genesis's solver; arm.py: the drive and the readings; world.py: the scene
and its step; body.py: an arm's ArmBody. docs/engines.md says what differs from MuJoCo.
"""

from __future__ import annotations

from franka_sim.physics.genesis.runtime import genesis_missing


def make_physics(placements, q0s, scene, *, mobile_base: bool = False):
    """The Genesis world of `placements` in `scene` and the arm's body in it."""
    if mobile_base:
        raise ValueError("the Genesis engine has no mobile base")
    from franka_sim.physics.engine import Physics
    from franka_sim.physics.genesis.body import GenesisArmBody
    from franka_sim.physics.genesis.world import GenesisWorld

    world = GenesisWorld(placements, q0s, scene_xml=scene)
    return Physics(world, tuple(GenesisArmBody(world, p.name) for p in placements))


__all__ = ["genesis_missing", "make_physics"]
