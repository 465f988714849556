"""Where the installed package keeps its own files (scenes/, urdf/): beside its modules, read by
path, as MuJoCo reads a scene's files. Not importlib.resources, whose imports cost ~1 MiB of a
server's memory for this one lookup."""

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
