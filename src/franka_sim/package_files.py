"""Where the installed package keeps its own files (scenes/, urdf/): beside its modules, read by
path, as MuJoCo reads a scene's files. Not importlib.resources: a server would keep its
modules (~0.1 MiB beside what a server imports anyway) for this one lookup."""

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
