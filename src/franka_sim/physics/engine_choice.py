"""The physics engines by name, and whether one can run here: what `serve --physics` and the
Config rules ask before anything imports numpy, MuJoCo or an engine (physics/engine.py builds
the world on the one chosen; docs/engines.md)."""

from __future__ import annotations

ENGINES = ("mujoco", "genesis")  # the first is the default


def engine_missing(engine: str) -> str | None:
    """One line saying what to install for `engine`; None if it can run here."""
    if engine == "genesis":
        from franka_sim.physics.genesis.runtime import genesis_missing

        return genesis_missing()
    return None
