"""A frame of `franka-sim render`'s, drawn in a child Python: MuJoCo picks its OpenGL backend
(MUJOCO_GL) once, when it is first imported, and in a test process something imported it long
before; the child sets EGL first, as `franka-sim render` does."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

_CHILD = r"""
import json, os, sys
os.environ.setdefault("MUJOCO_GL", "egl")
import numpy as np
from franka_sim.playback.render import Frames, RenderError
from franka_sim.recording.reader import open_recording
path, fps, which, meshes, out = sys.argv[1:6]
try:
    kw = dict(fps=float(fps), meshes=meshes or None)
    colour = Frames(open_recording(path), **kw)
    segments = Frames(open_recording(path), segmentation=True, **kw)
except RenderError as exc:
    print(json.dumps({"skip": str(exc)}))
    sys.exit(0)
k = int(float(which) * (len(colour.cycles) - 1))
for i, (rgb, seg) in enumerate(zip(colour, segments)):
    if i == k:
        break
model = colour.model
np.savez(out, rgb=rgb, seg=seg, groups=model.geom_group)
print(json.dumps({"names": [model.geom(g).name for g in range(model.ngeom)]}))
"""


def render_frame(recording: Path, tmp: Path, *, fps: float = 2.0, which: float = 0.5,
                 meshes: Path | None = None):
    """(rgb, geom id per pixel (-1: none), geom names, geom groups) of the frame `which` of
    the way through the recording's video; skips where there is no offscreen OpenGL."""
    out = tmp / "frame.npz"
    done = subprocess.run([sys.executable, "-c", _CHILD, str(recording), str(fps), str(which),
                           str(meshes or ""), str(out)], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    said = json.loads(done.stdout.strip().splitlines()[-1])
    if "skip" in said:
        pytest.skip(said["skip"])
    import mujoco

    arrays = np.load(out)
    seg = arrays["seg"]
    geoms = np.where(seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)
    return arrays["rgb"], geoms, said["names"], arrays["groups"]
