"""An older libfranka's own C++ examples, unmodified, run against a simulator.

The builds come from FRANKA_SIM_LIBFRANKA_BUILDS (build directories made by
build_older_libfranka.sh, separated by ':'); nothing here fetches or builds libfranka.

libfranka's Robot refuses to start a control loop unless /sys/kernel/realtime reads 1 (a
PREEMPT_RT kernel; the examples do not ask for RealtimeConfig::kIgnore). So each example that
opens a robot connection runs under franka_sim.testing.realtime_kernel.as_realtime (root).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time
from dataclasses import dataclass
from typing import Callable
from pathlib import Path

import numpy as np

from franka_sim.control import Control
from franka_sim.testing.realtime_kernel import as_realtime, cannot_fake

BUILDS_VARIABLE = "FRANKA_SIM_LIBFRANKA_BUILDS"
BUILD_SCRIPT = "tests/support/build_older_libfranka.sh"
# The robot protocol version each libfranka line speaks (its common/ submodule's kVersion).
# 0.20.5 on record a common commit no public mirror has; 0.21 is built with the newest public
# one (robot version 10, the commit 0.18.0 to 0.20.4 record), see build_older_libfranka.sh.
PROTOCOL = {(0, 9): 5, (0, 10): 6, (0, 11): 6, (0, 12): 6, (0, 13): 7, (0, 14): 8,
            (0, 15): 9, (0, 16): 9, (0, 17): 9, (0, 18): 10, (0, 19): 10, (0, 20): 10,
            (0, 21): 10}
GRIPPER_PROTOCOL = 3  # the same in every tag since 0.9
VACUUM_GRIPPER_PROTOCOL = 1  # likewise

@dataclass(frozen=True)
class Build:
    """A libfranka build directory and the version its library file names."""

    path: Path
    version: str

    @property
    def protocol(self) -> int:
        major, minor, _ = map(int, self.version.split("."))
        return PROTOCOL[major, minor]

    def example(self, name: str) -> Path:
        return self.path / "examples" / name


def builds() -> list[Build]:
    """The builds FRANKA_SIM_LIBFRANKA_BUILDS names (empty when it is unset)."""
    found = []
    for entry in filter(None, os.environ.get(BUILDS_VARIABLE, "").split(":")):
        path = Path(entry).resolve()
        libraries = sorted(path.glob("libfranka.so.*.*.*"))
        if not libraries:
            raise RuntimeError(f"{BUILDS_VARIABLE}: {path} holds no libfranka.so.X.Y.Z "
                               f"(a build directory of {BUILD_SCRIPT}?)")
        version = re.search(r"\.so\.(\d+\.\d+\.\d+)$", libraries[0].name).group(1)
        found.append(Build(path, version))
    return found


def cannot_run() -> str | None:
    """Why examples cannot run here (None: they can)."""
    if not os.environ.get(BUILDS_VARIABLE):
        return (f"{BUILDS_VARIABLE} is unset: build libfranka tags with {BUILD_SCRIPT} and "
                f"list their build directories in it")
    if why := cannot_fake():
        return f"libfranka's examples need /sys/kernel/realtime; {why}"
    return None


def grasp_pose() -> np.ndarray:
    """Joint angles with the open Hand around the default scene's cube."""
    import pick_and_place as pp
    return pp.poses_over(pp.CUBE, pp.READY)[1]


def pump_pose() -> np.ndarray:
    """Joint angles with the suction cup's lip 1 mm into the default scene's cube's top."""
    import pick_and_place as pp
    return pp.solve_ik(pp.CUBE + [0, 0, 0.024], pp.READY)


@dataclass(frozen=True)
class Example:
    """One example: its arguments after the host, whether it moves the arm, what its simulator
    serves beyond the defaults, and the joint angles the arm is put at before it runs."""

    name: str
    args: tuple[str, ...] = ()
    moves: bool = True
    realtime: bool = True  # it opens a robot connection (which wants /sys/kernel/realtime)
    serve: tuple[str, ...] = ()
    pre_move: Callable[[], np.ndarray] | None = None


EXAMPLES = {e.name: e for e in (
    Example("communication_test"),
    Example("echo_robot_state", moves=False),
    Example("generate_joint_position_motion"),
    Example("generate_cartesian_pose_motion"),
    Example("cartesian_impedance_control"),
    # homing, the cube's width
    Example("grasp_object", ("1", "0.05"), moves=False, pre_move=grasp_pose),
)}


# The pump's example, in the builds that have it, run with the vacuum gripper on the flange:
# after the pre-move it vacuums the cube, finds it held 3 s later and drops it off. It opens no
# robot connection.
VACUUM_OBJECT = Example("vacuum_object", moves=False, realtime=False, serve=("--tool", "vacuum"),
                        pre_move=pump_pose)
KNOWN = {**EXAMPLES, VACUUM_OBJECT.name: VACUUM_OBJECT}


@dataclass
class Run:
    returncode: int
    stdout: str
    stopped: bool  # cut short by `run` (after `cycles`), not ended by itself


def run(build: Build, name: str, host: str, cycles: int | None = None,
        timeout: float = 120.0) -> Run:
    """Run one example against the simulator at `host` (Enter typed for its prompt). With
    `cycles`, it is stopped (SIGTERM) once the robot has run that many cycles since it was
    first seen moving."""
    example, control = KNOWN[name], Control(host)
    if example.pre_move is not None:
        control.reset(q=example.pre_move().tolist())
    command = [str(build.example(name)), host, *example.args]
    proc = subprocess.Popen(as_realtime(command) if example.realtime else command,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    proc.stdin.write("\n")  # the Enter its prompt waits for
    proc.stdin.close()
    proc.stdin = None  # (so communicate() leaves it be)
    stopped, deadline = False, time.monotonic() + timeout
    if cycles is not None:
        moving_at = None
        while proc.poll() is None and time.monotonic() < deadline:
            health = control.health()
            if moving_at is None and health["robot_mode"] == "Move":
                moving_at = health["cycle"]
            if moving_at is not None and health["cycle"] - moving_at >= cycles:
                proc.send_signal(signal.SIGTERM)
                stopped = True
                break
            time.sleep(0.002)
    try:
        out, _ = proc.communicate(timeout=max(1.0, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        raise AssertionError(f"{name} of libfranka {build.version} hung:\n{out}") from None
    return Run(proc.returncode, out, stopped)
