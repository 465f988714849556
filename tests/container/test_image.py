"""The image, built and run for real: build_and_run.py against a docker daemon of the test's own.

`-m docker` selects these tests, `-m "not docker"` leaves them out. They skip only when docker
cannot run here at all (no dockerd, not root, a kernel it refuses); .ci/run installs docker.io
and debootstrap. A cold run (no cached base) takes ~2-3 minutes on 2 cores.
"""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
SCRIPT = HERE / "build_and_run.py"
IMAGE = "franka-sim:selftest"

pytestmark = pytest.mark.docker


def _script(*args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


def _failure_line(done: subprocess.CompletedProcess) -> str:
    assert done.returncode == 1, done.stdout + done.stderr
    return done.stderr.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def daemon():
    """A private dockerd for this module, started and stopped by pid."""
    sys.path.insert(0, str(HERE))
    from docker_cli import StepFailed
    from docker_daemon import PrivateDaemon

    daemon = PrivateDaemon(Path(tempfile.mkdtemp(prefix="fsim-dockerd-")))
    try:
        docker = daemon.start()
    except StepFailed as exc:
        daemon.stop()
        pytest.skip(f"docker cannot run on this machine: {exc}")
    docker.no_bridge = daemon.no_bridge  # why containers cannot have a bridge (None: they can)
    yield docker
    daemon.stop()


@pytest.fixture(scope="module")
def built(daemon, tmp_path_factory):
    """The whole self-test once: its report (the image stays on the module's daemon)."""
    report = tmp_path_factory.mktemp("selftest") / "report.json"
    done = _script("--docker-host", daemon.url, "--image", IMAGE, "--host", "127.0.0.77",
                   "--report", str(report))
    print(done.stdout)
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}"
    return json.loads(report.read_text())


def test_the_image_builds_offline_serves_pylibfranka_and_stops_on_sigterm(built, daemon):
    # 428 MB with the web and record extras: the test's Debian base carries the Python headers for the
    # build stage (libpython3.11-dev, ~52 MB with its static library; python:3.11-slim has them)
    assert built["image_mb"] < 450
    assert "web_s" in built  # its web view served its page
    # An older client's LoadModelLibrary (protocol 5) for Linux x86_64 and aarch64: each that
    # architecture's ELF library, prebuilt (fr3's and fer's, ~85 KB each; the image has no
    # compiler, nor the ziglang that built them).
    assert 20_000 < built["library_x86_64_bytes"] < 500_000
    assert 20_000 < built["library_aarch64_bytes"] < 500_000
    assert built["prebuilt_libraries"] == 4 and built["prebuilt_bytes"] < 1_000_000
    assert built["kernels_compiled"]  # the build stage's zig compiled them (hatch_build.py)
    assert built["bytecode"]  # (the runtime sets PYTHONDONTWRITEBYTECODE: pip compiled it)
    assert built["stop_s"] < 3.0  # docker stop's kill timeout is 10 s
    assert not daemon.run("stop", "ps", "--all", "--quiet").stdout.strip()  # nothing left


def test_published_ports_on_the_default_bridge_serve_pylibfranka_every_way_in(built, daemon,
                                                                            tmp_path):
    """`docker run -p`: through the published loopback address (the userland proxy), an
    address of the host's own (NAT: the answers come from the bridge's gateway, and the server
    follows them) and from another network namespace (NAT both ways)."""
    if daemon.no_bridge:
        pytest.skip(f"the private daemon has no bridge here: {daemon.no_bridge}")
    report = tmp_path / "bridge.json"
    done = _script("--docker-host", daemon.url, "--image", IMAGE, "--skip-build", "--bridge",
                   "--host", "127.0.0.79", "--report", str(report), timeout=300)
    print(done.stdout)
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}"
    ways = json.loads(report.read_text())
    loopback, own, namespace, gateway = (ways[k] for k in ("loopback", "own", "namespace",
                                                           "gateway"))
    # the proxy connects from the gateway, and the answers come from there too
    assert loopback["tcp_peer"] == gateway and loopback["answers_moved"] is None
    # NAT both ways: the client's own address, for the connection and the answers alike
    assert namespace["tcp_peer"] == ways["namespace_client"]
    assert namespace["answers_moved"] is None
    # NAT, no proxy: the connection from the host's own address, the answers from the gateway
    assert own["tcp_peer"] == own["address"]
    assert f"client at {own['address']} come from {gateway}:" in own["answers_moved"]
    assert ways["stop_s"] < 3.0
    assert not daemon.run("stop", "ps", "--all", "--quiet").stdout.strip()
    links = subprocess.run(["ip", "-o", "link"], capture_output=True, text=True).stdout
    assert "fsimown" not in links and "fsimva" not in links  # the run's devices are gone
    assert "fsimns" not in subprocess.run(["ip", "netns"], capture_output=True, text=True).stdout


def test_a_taken_port_fails_the_run_step_in_one_line(built, daemon):
    host = "127.0.0.78"
    with socket.socket() as taken:
        taken.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        taken.bind((host, 1337))
        taken.listen()
        done = _script("--docker-host", daemon.url, "--image", IMAGE, "--skip-build",
                       "--host", host, timeout=120)
    line = _failure_line(done)
    assert line.startswith("container test: run failed: the container exited (1)"), line
    assert f"{host}:1337 is already in use" in line
    assert not daemon.run("stop", "ps", "--all", "--quiet").stdout.strip()


def test_a_failed_build_names_the_build_step(daemon, tmp_path):
    empty = tmp_path / "empty.tar"  # a base with no shell, let alone python3
    subprocess.run(["tar", "-cf", str(empty), "--files-from", "/dev/null"], check=True)
    daemon.run("build", "import", str(empty), "local/empty-base")
    done = _script("--docker-host", daemon.url, "--image", "franka-sim:broken",
                   "--base-image", "local/empty-base", timeout=300)
    line = _failure_line(done)
    assert line.startswith("container test: build failed: `docker build`:"), line
    assert not daemon.run("stop", "ps", "--all", "--quiet").stdout.strip()


def test_an_unreachable_daemon_fails_the_daemon_step_in_one_line(tmp_path):
    if shutil.which("docker") is None:
        pytest.skip("no docker client here (Debian: docker.io)")
    done = _script("--docker-host", f"unix://{tmp_path}/no-daemon.sock", timeout=60)
    line = _failure_line(done)
    assert line.startswith(f"container test: daemon failed: cannot reach unix://{tmp_path}"), line


def _container(daemon, name: str, *options: str, command: tuple[str, ...] = ()) -> None:
    """`docker run --detach` of the built image on the host network with `serve`'s flags
    `command`, until every robot serves (fails with its last line should it exit instead)."""
    daemon.run("run", "run", "--detach", "--pull", "never", "--name", name, "--network", "host",
               *options, IMAGE, *command)
    robots = 1 + sum(flag in ("--arm", "--mobile-base") for flag in command) - (
        "--arm" in command)
    for _ in range(600):
        logs = daemon.run("run", "logs", name).stderr
        if logs.count("serving on") >= robots:
            return
        if daemon.inspect("run", name, "{{.State.Status}}") == "exited":
            logs = daemon.run("run", "logs", name).stderr
            pytest.fail(f"{name} exited: {logs.strip().splitlines()[-1:]}")
        time.sleep(0.2)
    pytest.fail(f"{name} did not serve: {logs}")


@pytest.fixture
def removed(daemon):
    """Names of the containers and volumes a test makes: removed after it, whatever happened."""
    made = {"containers": [], "volumes": []}
    yield made
    for name in made["containers"]:
        daemon.run("stop", "rm", "--force", name, check=False)
    for name in made["volumes"]:
        daemon.run("stop", "volume", "rm", "--force", name, check=False)


def test_the_health_check_asks_every_robot_however_they_are_configured(built, daemon, removed):
    """Flags the health check cannot see: several arms, a mobile base, a control port other
    than 1340 and a token. It reads what the server wrote to FRANKA_SIM_SERVING_FILE."""
    from build_and_run import healthy

    name = "fsim-health-arms"
    removed["containers"].append(name)
    left, right, base = "127.0.0.160", "127.0.0.161", "127.0.0.162"
    _container(daemon, name, command=(
        "--scene", "mobile_duo", "--arm", f"left={left}", "--arm", f"right={right}",
        "--mobile-base", base, "--control-port", "1341", "--control-token", "s3cret"))
    healthy(daemon, name)
    # the check as the health check runs it, and what it read
    assert daemon.run("exec", "exec", name, "franka-sim", "check").returncode == 0
    served = json.loads(daemon.run("exec", "exec", name, "sh", "-c",
                                   'cat "$FRANKA_SIM_SERVING_FILE"').stdout)
    assert [(r["host"], r["control_port"]) for r in served["robots"]] == [
        (left, 1341), (right, 1341), (base, 1341)]


def test_it_records_to_a_named_volume_and_the_image_replays_it_identically(built, daemon,
                                                                          removed):
    """The image carries the `record` extra, and a named volume on its recordings folder is the
    image user's (Docker copies the folder's owner into a new volume)."""
    sys.path.insert(0, str(HERE))
    from drive import drive_apart

    host, name, volume = "127.0.0.163", "fsim-record", "fsim-recordings"
    removed["containers"].append(name)
    removed["volumes"].append(volume)
    folder = "/home/franka-sim/recordings"
    _container(daemon, name, "--env", f"FRANKA_SIM_HOST={host}", "--volume",
               f"{volume}:{folder}", command=("--record", f"{folder}/run.mcap"))
    drive_apart(host, "drive")
    daemon.run("stop", "stop", name, timeout=30)
    assert daemon.inspect("stop", name, "{{.State.ExitCode}}") == "0"
    replay = daemon.run("replay", "run", "--rm", "--pull", "never", "--network", "none",
                        "--volume", f"{volume}:{folder}", "--entrypoint", "franka-sim", IMAGE,
                        "replay", f"{folder}/run.mcap", timeout=300, check=False)
    assert replay.returncode == 0, replay.stdout + replay.stderr
    assert "identical" in replay.stdout + replay.stderr


def test_the_desk_certificate_is_kept_in_a_named_volume(built, daemon, removed):
    host, name, volume = "127.0.0.164", "fsim-desk", "fsim-desk-certificate"
    removed["containers"].append(name)
    removed["volumes"].append(volume)
    folder = "/home/franka-sim/.local/share/franka-sim/desk"
    _container(daemon, name, "--env", f"FRANKA_SIM_HOST={host}", "--env",
               "FRANKA_SIM_DESK_PORT=8443", "--volume", f"{volume}:{folder}")
    kept = daemon.run("stop", "run", "--rm", "--pull", "never", "--network", "none",
                      "--volume", f"{volume}:{folder}", "--entrypoint", "ls", IMAGE, folder)
    assert kept.stdout.split(), "the certificate was not written to the volume"


def _capabilities(daemon, name: str) -> int:
    status = daemon.run("exec", "exec", name, "cat", "/proc/1/status").stdout
    return int(status.split("CapEff:")[1].split()[0], 16)


def test_rt_priority_has_its_capability_only_as_root(built, daemon, removed):
    """--cap-add SYS_NICE gives the capability to root only: the image's user 10001 runs with
    none in effect, and SCHED_FIFO is refused to it."""
    sys_nice = 1 << 23
    for host, name, user in (("127.0.0.165", "fsim-rt-user", ()),
                             ("127.0.0.166", "fsim-rt-root", ("--user", "0"))):
        removed["containers"].append(name)
        _container(daemon, name, "--env", f"FRANKA_SIM_HOST={host}", "--cap-add", "SYS_NICE",
                   *user, command=("--rt-priority", "10"))
        assert bool(_capabilities(daemon, name) & sys_nice) == bool(user), name
    logs = daemon.run("logs", "logs", "fsim-rt-user").stderr
    assert "--rt-priority 10 not applied (Operation not permitted)" in logs
