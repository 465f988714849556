"""An older libfranka client's model library from a served image, and what the image carries.

    python tests/container/older_client.py HOST

`load_model_library`: the request libfranka 0.9.2 (robot protocol 5, protocol_specs/robot_v5.md)
sends after its Connect, before it builds its Model, over a raw socket; the answer's status and
the library's ELF header. `model_libraries`: that for a client of each Linux architecture the
image has libraries for, and, inside the image, each packaged robot's prebuilt library, and no
compiler (neither `cc` nor the ziglang package that built them). Fails with
"container test: library failed: why".
"""

from __future__ import annotations

import json
import socket
import struct
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))  # tests/: support/

from docker_cli import StepFailed  # noqa: E402
from support.elf import elf_machine  # noqa: E402
from franka_sim.blocking_io import recv_exact  # noqa: E402

ROBOT_PORT = 1337
VERSION = 5
CONNECT, LOAD_MODEL_LIBRARY = 0, 13  # v5's command ids
ARCHITECTURES = {"x86_64": 0, "aarch64": 3}  # libfranka's Architecture: kX64, kARM64
LINUX = 0  # System::kLinux

# Run in the image: its prebuilt libraries, one per packaged robot and target, and no compiler.
IN_IMAGE = """
import importlib.util, json, os, shutil
from pathlib import Path
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.model_library.build import ZIG_TARGETS, library_name, target_text
from franka_sim.model_library.source import c_source
place = Path(os.environ["FRANKA_SIM_MODEL_LIBRARIES"])
missing = [f"{robot} {target_text(target)}" for robot in ("fr3", "fer") for target in ZIG_TARGETS
           if not (place / library_name(c_source(load_arm_description(default_urdf_text(robot))),
                                        target)).is_file()]
print(json.dumps({"files": sorted(p.name for p in place.iterdir()), "missing": missing,
                  "bytes": sum(p.stat().st_size for p in place.iterdir()),
                  "cc": shutil.which("cc") or shutil.which("gcc"),
                  "ziglang": importlib.util.find_spec("ziglang") is not None}))
"""


def load_model_library(host: str, architecture: str) -> tuple[int, bytes]:
    """(status, library) of a v5 client's LoadModelLibrary for Linux on `architecture`."""
    try:
        return _load_model_library(host, architecture)
    except ConnectionError as exc:
        raise StepFailed("library", f"the robot closed the connection: {exc}") from None


def _load_model_library(host: str, architecture: str) -> tuple[int, bytes]:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp, \
            socket.create_connection((host, ROBOT_PORT), timeout=30,
                                     source_address=(host, 0)) as tcp:
        udp.bind((host, 0))  # where the states go (this client reads none)
        tcp.sendall(struct.pack("<IIIHH", CONNECT, 0, 16, VERSION, udp.getsockname()[1]))
        command, _, _, status, version = struct.unpack("<IIIBH", recv_exact(tcp, 15))
        if (command, status, version) != (CONNECT, 0, VERSION):
            raise StepFailed("library", f"Connect of version {VERSION} answered status {status}"
                                        f" (version {version})")
        tcp.sendall(struct.pack("<IIIBB", LOAD_MODEL_LIBRARY, 1, 14,
                                ARCHITECTURES[architecture], LINUX))
        command, command_id, size = struct.unpack("<III", recv_exact(tcp, 12))
        if (command, command_id) != (LOAD_MODEL_LIBRARY, 1) or size < 13:
            raise StepFailed("library", f"LoadModelLibrary answered by command {command}, "
                                        f"id {command_id}, {size} bytes")
        body = recv_exact(tcp, size - 12)
    return body[0], body[1:]


def model_libraries(host: str, docker=None, image: str | None = None) -> dict:
    """Each architecture's library as a v5 client gets it (its size), and with `docker` and
    `image` what the image carries; StepFailed("library") where one is missing or wrong."""
    report: dict = {}
    for architecture in ARCHITECTURES:
        status, library = load_model_library(host, architecture)
        if status != 0:  # kSuccess
            raise StepFailed("library", f"LoadModelLibrary for {architecture} Linux answered "
                                        f"status {status} (kError), not kSuccess")
        got = elf_machine(library)
        if got != architecture:
            raise StepFailed("library", f"the library for {architecture} is {got or 'no'} "
                                        f"ELF shared object ({len(library)} bytes)")
        report[f"library_{architecture}_bytes"] = len(library)
    if docker is not None:
        done = docker.run("library", "run", "--rm", "--pull", "never", "--network", "none",
                          "--entrypoint", "python", image, "-c", IN_IMAGE)
        carried = json.loads(done.stdout)
        if carried["missing"] or carried["cc"] or carried["ziglang"]:
            raise StepFailed("library", f"the image's model libraries: {carried}")
        report["prebuilt_libraries"] = len(carried["files"])
        report["prebuilt_bytes"] = carried["bytes"]
    return report


if __name__ == "__main__":
    try:
        print(json.dumps(model_libraries(sys.argv[1])))
    except StepFailed as exc:
        print(f"container test: {exc}", file=sys.stderr)
        sys.exit(1)
