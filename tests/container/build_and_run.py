"""Build the image offline from Debian's packages, run it on the host network, drive it.

    python tests/container/build_and_run.py [--host 127.0.0.77] [--docker-host URL] [--bridge]

Each step names itself when it fails, in one line on stderr ("container test: STEP failed:
why") with exit status 1, and whatever the run started is stopped and removed first:
  daemon  a private dockerd (or the one at --docker-host), reachable
  base    a python3 base image made with debootstrap (debian_base.py)
  wheels  the runtime dependencies and the build backend, as wheels made on this host
  build   the image from the repository's Dockerfile, with no network inside the build
  run     the container, --network host, serving on --host, its web view on 8080
  health  its HEALTHCHECK (`franka-sim check`) turns healthy
  drive   pylibfranka from this host: connect, a short joint motion, the Hand's homing
  library an older client's (protocol 5) LoadModelLibrary for Linux x86_64 and aarch64: each
          answered with that architecture's ELF library; inside the image, each packaged
          robot's prebuilt libraries and no compiler (older_client.py)
  web     the web view's page from the image (the `web` extra, nothing fetched)
  stop    `docker stop` (SIGTERM to PID 1) ends it at once and cleanly (exit status 0)
With --bridge, run, health and drive are instead (published.py):
  publish the container on the daemon's default bridge, ports 1337, 1338 and 1340 published on
          --host, an address of the host's own and a link to another network namespace
          (`network`: made for the run, needs root and iproute2)
  drive (WAY, ADDRESS)   pylibfranka through each of them, and the control API
On success it prints what each step took and the image's size (--report FILE: as JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from contextlib import ExitStack
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from debian_base import base_image, default_cache  # noqa: E402
from docker_cli import Docker, StepFailed, last_line  # noqa: E402
from docker_daemon import PrivateDaemon  # noqa: E402
from drive import drive  # noqa: E402
from older_client import model_libraries  # noqa: E402

import published  # noqa: E402

ROOT = HERE.parents[1]
NOT_IN_CONTEXT = (".git", ".venv", "wheelhouse", "__pycache__", "*.pyc", ".pytest_cache",
                  "build", "dist", "*.egg-info")
BASE_NAME = "local/python-base"


def wheels(context: Path) -> Path:
    """The runtime requirements and the build backend as wheels, pinned to the versions this
    environment runs (so the image runs what the tests ran), in `context`/wheelhouse."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    extras = project["project"]["optional-dependencies"]
    wanted = (project["project"]["dependencies"] + project["build-system"]["requires"]
              + extras["web"]  # the image has the view
              + extras["record"]  # and records
              + extras["zig"])  # its build stage compiles the model libraries with it
    pins = "".join(f"{d.metadata['Name']}=={d.version}\n" for d in metadata.distributions()
                   if d.metadata["Name"] and d.metadata["Name"].lower() != "franka-sim")
    constraints = context.parent / "constraints.txt"
    constraints.write_text(pins)
    house = context / "wheelhouse"
    command = [sys.executable, "-m", "pip", "wheel", "--quiet", "--disable-pip-version-check",
               "--wheel-dir", str(house), "--constraint", str(constraints), *wanted]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=600,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        raise StepFailed("wheels", "pip wheel took over 10 minutes") from None
    if done.returncode != 0:
        raise StepFailed("wheels", f"pip wheel: {last_line(done.stderr + done.stdout)}")
    return house


def build_context(work: Path) -> Path:
    context = work / "context"
    shutil.copytree(ROOT, context, ignore=shutil.ignore_patterns(*NOT_IN_CONTEXT), symlinks=True)
    return context


def python_of(docker: Docker, image: str) -> tuple[int, int]:
    done = docker.run("base", "run", "--rm", "--pull", "never", "--network", "none",
                      "--entrypoint", "python3",
                      image, "-c", "import sys; print(*sys.version_info[:2])")
    major, minor = done.stdout.split()
    return int(major), int(minor)


def compiled(docker: Docker, image: str) -> dict:
    """Whether the image runs the cycle's compiled kernels (built by its build stage's zig), and
    whether franka_sim's bytecode is in it (pip compiled it: a start compiles nothing)."""
    done = docker.run("kernels", "run", "--rm", "--pull", "never", "--network", "none",
                      "--entrypoint", "python", image, "-c",
                      "import importlib.util, json, os, franka_sim.kernels as k, franka_sim.launch"
                      " as l; print(json.dumps({'kernels_compiled': k.COMPILED, 'bytecode': "
                      "os.path.exists(importlib.util.cache_from_source(l.__file__))}))")
    return json.loads(done.stdout)


def build(docker: Docker, context: Path, base: str, image: str, logs: Path) -> None:
    docker.run("build", "build", "--network", "none", "--force-rm",
               "--build-arg", f"BASE_IMAGE={base}", "--tag", image, str(context),
               timeout=900, log=logs / "build.log")


def run(docker: Docker, image: str, name: str, *network: str, timeout: float = 60.0) -> float:
    """Start the container with `network`'s options (e.g. `--network host --env
    FRANKA_SIM_HOST=...`); seconds until it serves. A container that exits instead (a taken
    port, a bad flag) fails this step with its last line."""
    start = time.monotonic()
    docker.run("run", "run", "--detach", "--pull", "never", "--name", name, *network, image)
    while time.monotonic() - start < timeout:
        logs = docker.run("run", "logs", name).stderr
        if "serving on" in logs:
            return time.monotonic() - start
        if docker.inspect("run", name, "{{.State.Status}}") == "exited":
            code = docker.inspect("run", name, "{{.State.ExitCode}}")
            # read again: the logs above may have been read before its last words
            logs = docker.run("run", "logs", name).stderr
            raise StepFailed("run", f"the container exited ({code}): {last_line(logs)}")
        time.sleep(0.2)
    raise StepFailed("run", f"not serving after {timeout:.0f} s")


WEB_PORT = 8080


def web_page(host: str) -> None:
    """The web view's page, served from the image's installed viser client."""
    import urllib.request

    try:
        with urllib.request.urlopen(f"http://{host}:{WEB_PORT}/", timeout=30) as page:
            body = page.read()
    except OSError as exc:
        raise StepFailed("web", f"no page on {host}:{WEB_PORT}: {exc}") from None
    if b"<html" not in body[:4000].lower():
        raise StepFailed("web", f"{host}:{WEB_PORT} answered no HTML page")


def healthy(docker: Docker, name: str, timeout: float = 90.0) -> float:
    """Seconds until Docker reports the HEALTHCHECK healthy."""
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        health = json.loads(docker.inspect("health", name, "{{json .State.Health}}") or "null")
        status = (health or {}).get("Status")
        if status == "healthy":
            return time.monotonic() - start
        if status == "unhealthy":
            output = (health["Log"] or [{}])[-1].get("Output", "")
            raise StepFailed("health", f"unhealthy: {last_line(output)}")
        if docker.inspect("health", name, "{{.State.Status}}") != "running":
            raise StepFailed("health", "the container stopped before it was healthy")
        time.sleep(0.5)
    raise StepFailed("health", f"not healthy after {timeout:.0f} s")


def stop(docker: Docker, name: str, limit: float = 3.0) -> float:
    """Seconds `docker stop` took (its kill timeout is 10 s: a server that ignores SIGTERM
    takes that long and exits 137)."""
    start = time.monotonic()
    docker.run("stop", "stop", "--time", "10", name, timeout=30)
    took = time.monotonic() - start
    code = docker.inspect("stop", name, "{{.State.ExitCode}}")
    if code != "0" or took > limit:
        raise StepFailed("stop", f"docker stop took {took:.2f} s, exit status {code} "
                                 f"(wanted under {limit:.0f} s and 0)")
    return took


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.77",
                        help="loopback address the container serves on (host network)")
    parser.add_argument("--docker-host", help="use this daemon (unix://...) instead of "
                        "starting one")
    parser.add_argument("--image", default="franka-sim:selftest", help="tag of the image")
    parser.add_argument("--skip-build", action="store_true",
                        help="run --image as it is (it must exist on the daemon)")
    parser.add_argument("--base-image", help="build FROM this image instead of making one")
    parser.add_argument("--cache", type=Path, default=default_cache(),
                        help="where the base's root file system is kept between runs")
    parser.add_argument("--logs", type=Path, help="keep the build log here")
    parser.add_argument("--report", type=Path, help="write the measurements here as JSON")
    parser.add_argument("--bridge", action="store_true",
                        help="run on the daemon's default bridge with the ports published on "
                        "--host, an address of the host's own and a link to another network "
                        "namespace, and drive it through each (published.py)")
    args = parser.parse_args(argv)
    # Nothing here is real-time: pip, debootstrap and docker run under the normal policy even
    # when started from a test process that pylibfranka left under SCHED_FIFO.
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    report: dict = {}
    try:
        with ExitStack() as cleanup:
            report = _steps(args, cleanup)
    except StepFailed as exc:
        print(f"container test: {exc}", file=sys.stderr)
        return 1
    print("container test: ok: " + ", ".join(f"{k} {v}" for k, v in report.items()), flush=True)
    if args.report:
        args.report.write_text(json.dumps(report, indent=1))
    return 0


def _steps(args, cleanup: ExitStack) -> dict:
    report: dict = {}
    clock = time.monotonic()

    def took(step: str) -> None:
        nonlocal clock
        report[f"{step}_s"] = round(time.monotonic() - clock, 2)
        print(f"container test: {step} done in {report[f'{step}_s']:.1f} s", flush=True)
        clock = time.monotonic()

    work = Path(tempfile.mkdtemp(prefix="fsim-selftest-"))
    cleanup.callback(shutil.rmtree, work, ignore_errors=True)
    if args.docker_host:
        docker = Docker(args.docker_host, work)
        why = docker.reachable()
        if why is not None:
            raise StepFailed("daemon", f"cannot reach {args.docker_host}: {why}")
    else:
        daemon = PrivateDaemon(Path(tempfile.mkdtemp(prefix="fsim-dockerd-")))
        cleanup.callback(daemon.stop)
        docker = daemon.start()
    took("daemon")
    if not args.skip_build:
        base = args.base_image or base_image(docker, BASE_NAME, args.cache)
        took("base")
        context = build_context(work)
        if args.base_image is None and python_of(docker, base) != sys.version_info[:2]:
            raise StepFailed("wheels", f"this host runs Python {sys.version_info[0]}."
                             f"{sys.version_info[1]}, the base image another: wheels won't fit")
        wheels(context)
        took("wheels")
        logs = args.logs or work
        logs.mkdir(parents=True, exist_ok=True)
        build(docker, context, base, args.image, logs)
        took("build")
    report["image_mb"] = round(int(docker.inspect("build", args.image, "{{.Size}}")) / 1e6)
    report.update(compiled(docker, args.image))
    name = f"franka-sim-selftest-{int(time.time() * 1000) % 10**8}"
    cleanup.callback(docker.run, "stop", "rm", "--force", name, check=False)
    if args.bridge:
        report.update(published.run_and_drive(docker, args.image, name, args.host, cleanup, run))
        report["stop_s"] = round(stop(docker, name), 2)
        return report
    run(docker, args.image, name, "--network", "host", "--env", f"FRANKA_SIM_HOST={args.host}",
        "--env", f"FRANKA_SIM_WEB_PORT={WEB_PORT}")
    took("run")
    healthy(docker, name)
    took("health")
    drive(args.host)
    took("drive")
    report.update(model_libraries(args.host, docker, args.image))
    took("library")
    web_page(args.host)
    took("web")
    report["stop_s"] = round(stop(docker, name), 2)
    return report


if __name__ == "__main__":
    sys.exit(main())
