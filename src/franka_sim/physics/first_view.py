"""Where a first look at the world stands: every arm in view, from the front right.

The web view (web/world_view.py) and the MuJoCo viewer (server/viewer.py) open on it, so a
world of several arms or a mobile base opens on its arms, not on whatever MuJoCo's free
camera frames (the model's centre and extent: a close-up of the base's column).
"""

from __future__ import annotations

import math

import numpy as np


def first_view(model, data) -> tuple[np.ndarray, np.ndarray]:
    """(position, look_at) of a first view of every arm: from the front right, above the
    middle of their bases (`data`'s, forward-computed), further back the further apart they
    stand."""
    bases = np.array([data.xpos[b] for b in range(model.nbody)
                      if model.body(b).name.split("/")[-1] == "link0"])
    middle = bases.mean(axis=0) if len(bases) else np.zeros(3)
    spread = float(np.ptp(bases, axis=0).max()) if len(bases) > 1 else 0.0
    look_at = middle + (0.3, 0.0, 0.35)
    return look_at + (0.95 + 0.4 * spread, -0.95 - 0.8 * spread, 0.5 + 0.3 * spread), look_at


def orbit(position: np.ndarray, look_at: np.ndarray) -> tuple[float, float, float]:
    """The same view as a MuJoCo free camera's (distance, azimuth, elevation in degrees)
    about `look_at`."""
    forward = np.asarray(look_at, float) - np.asarray(position, float)
    distance = float(np.linalg.norm(forward))
    x, y, z = forward / distance
    return distance, math.degrees(math.atan2(y, x)), math.degrees(math.asin(z))


def aim(camera, model, data, back_off: float = 1.0) -> None:
    """Point a MuJoCo free camera (MjvCamera) at the first view of `data`'s world, `back_off`
    times as far from what it looks at (the viewer's window, render's smaller video)."""
    position, look_at = first_view(model, data)
    distance, camera.azimuth, camera.elevation = orbit(position, look_at)
    camera.lookat[:] = look_at
    camera.distance = back_off * distance
