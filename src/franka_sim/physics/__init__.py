"""Physics: the Backend protocol, the MuJoCo world of N arms and the one-arm Backend over it
(synchronous; one owner thread)."""

import os

# The simulator never renders. Without this, importing mujoco loads an OpenGL/GLFW stack,
# which costs ~0.6 s of start-up on a headless machine. A caller who does render (and set
# MUJOCO_GL itself, or imported mujoco first) is unaffected.
os.environ.setdefault("MUJOCO_GL", "disable")
