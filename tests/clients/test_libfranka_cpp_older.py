"""libfranka's own C++ examples of older tags (0.9.2: robot protocol 5, 0.12.1: 6, 0.13.6: 7,
0.14.1: 8, 0.15.3: 9) and of 0.21.2 (10, the simulator's own; built with libfranka-common
d96c221 in place of the commit 2e090a6 it records, which is not public: docs/clients.md),
built from their sources and run unmodified against the simulator in lockstep: each prints
what it prints on a robot, and the recording of its run shows the robot did what it asked
(tests/support/libfranka_cpp_checks.py).

The sources cannot be fetched here, so the builds are the user's: build a tag's checkout with
tests/support/build_older_libfranka.sh and list the build directories in
FRANKA_SIM_LIBFRANKA_BUILDS (':'-separated); without it every test skips and says so. The
committed recordings of such runs are replayed where no build exists
(tests/recording/test_libfranka_cpp_recordings.py).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from franka_sim.control import Control
from franka_sim.protocol import ROBOT_VERSION
from franka_sim.recording.reader import open_recording
from franka_sim.testing import running_sim
from support import libfranka_cpp as cpp
from support.libfranka_cpp_checks import CHECKS, READY, connect_versions, requests

REASON = cpp.cannot_run()
BUILDS = [] if REASON else cpp.builds()
pytestmark = pytest.mark.skipif(REASON is not None, reason=REASON or "")
IMPEDANCE_CYCLES = 3000  # cartesian_impedance_control runs until stopped: this many cycles


@pytest.fixture(scope="module", params=BUILDS or [None],
                ids=lambda b: b.version if b else "none")
def build(request) -> cpp.Build:
    return request.param


@pytest.fixture(scope="module", params=list(cpp.EXAMPLES))
def ran(request, build, tmp_path_factory):
    """(the example's run, its recording, the arm's state and the cube's position after)."""
    name = request.param
    recording = tmp_path_factory.mktemp(f"{build.version}-{name}") / "run.mcap"
    with running_sim("--clock", "lockstep", "--record", str(recording)) as sim:
        if name == "cartesian_impedance_control":
            run = cpp.run(build, name, sim.host, cycles=IMPEDANCE_CYCLES)
        else:
            run = cpp.run(build, name, sim.host)
        control = Control(sim.host)
        after = control.state(), control.pose("cube")["position"]
        if name != "grasp_object" and build.protocol != ROBOT_VERSION:  # through a dialect
            assert sim.log_matching(
                f"client speaks robot protocol version {build.protocol}: served as such")
    return name, run, open_recording(recording), *after


def test_it_prints_what_it_does_on_a_robot(ran, build):
    name, run, *_ = ran
    out = run.stdout
    if name == "cartesian_impedance_control":
        assert run.stopped and "Press Enter to continue" in out, out
        return
    assert run.returncode == 0, out
    expected = {
        "communication_test": ["Finished test, shutting down example",
                               "Control command success rate of 10000 samples",
                               "Max: 1.00", "Avg: 1.00", "Min: 1.00"],
        "echo_robot_state": ["Done."],
        "generate_joint_position_motion": ["Finished moving to initial joint configuration.",
                                           "Finished motion, shutting down example"],
        "generate_cartesian_pose_motion": ["Finished moving to initial joint configuration.",
                                           "Finished motion, shutting down example"],
        "grasp_object": ["Grasped object, will release it now."],
    }[name]
    for line in expected:
        assert line in out, out
    assert "WARNING: MANY PACKETS GOT LOST" not in out and "not get executed" not in out
    if name == "echo_robot_state":  # 101 states, each printed as JSON
        states = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
        assert len(states) == 101
        assert all(s["robot_mode"] == "Idle" and not s["current_errors"] for s in states)
        assert np.allclose(states[-1]["q"], READY, atol=1e-5)  # (printed with 6 digits)


def test_it_connects_with_its_tags_protocol(ran, build):
    name, _, recording, *_ = ran
    versions = connect_versions(recording)
    if name == "grasp_object":
        assert versions == {"hand": cpp.GRIPPER_PROTOCOL}
    else:
        assert versions == {"robot": build.protocol}
    assert all("command" in request for request in requests(recording))  # each one read


def test_the_robot_did_what_it_asked(ran):
    name, run, recording, state, cube = ran
    CHECKS[name](recording, complete=not run.stopped)
    assert state["robot_mode"] == "Idle" and not state["errors"], state
    if name == "grasp_object":  # held between the fingers, not knocked off
        assert np.linalg.norm(np.subtract(cube, [0.45, 0.0, 0.025])) < 5e-3, cube
