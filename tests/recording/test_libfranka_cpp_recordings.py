"""Older libfranka's own C++ examples (vacuum_object too), where no libfranka build can be had
(CI): their
committed recordings (tests/data/older_libfranka/<tag>/<example>.mcap, made by
tests/support/record_older_libfranka.py from runs of tests/clients/test_libfranka_cpp_older.py's
examples) replayed.

What this proves: each file holds a real libfranka client's bytes as that tag wrote them (its
Connect, its requests, its commands, ended or cut) and our server's answers, states and
physics; `franka-sim replay` feeds those bytes to today's simulator and gets the same states
bit for bit, so today's server reads that tag's requests and command datagrams as it did when
the example ran and passed; and the recording shows the tag's protocol version at Connect and
the example's motion (tests/support/libfranka_cpp_checks.py).

What it does not prove: replay does not run libfranka, so nothing here checks how a client of
today's server reads its replies and states (the 2373-byte float64 RobotState, statuses by
name, the model library); the live runs and the golden vectors of
tests/protocol/test_robot_v5.py and test_robot_v9.py do. The long examples are kept only up to
a few hundred cycles of their motion (record_older_libfranka.CUTS); their whole runs, and the
examples' printed output, are checked live.

When the recording format or the simulator's behaviour changes, these files no longer replay
identical: rebuild the tags (tests/support/build_older_libfranka.sh) and rewrite them with
record_older_libfranka.py.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from franka_sim.recording.reader import open_recording
from support import libfranka_cpp as cpp
from support.libfranka_cpp_checks import CHECKS, connect_versions, requests
from support.replayed import replay_committed
from support.record_older_libfranka import CUTS, DATA

TAGS = ("0.9.2", "0.12.1", "0.13.6", "0.14.1", "0.15.3", "0.21.2")
REGENERATE = ("rewrite them: build the tags with tests/support/build_older_libfranka.sh, then "
              "FRANKA_SIM_LIBFRANKA_BUILDS=... python tests/support/record_older_libfranka.py")
PUMP_TAGS = ("0.9.2", "0.13.6", "0.15.3", "0.21.2")  # the builds with vacuum_object
FILES = [(tag, name) for tag in TAGS for name in cpp.EXAMPLES] + [
    (tag, "vacuum_object") for tag in PUMP_TAGS]


def test_every_tag_and_example_is_recorded():
    assert sorted(p.relative_to(DATA).as_posix() for p in DATA.glob("*/*.mcap")) == \
        sorted(f"{tag}/{name}.mcap" for tag, name in FILES)
    assert sum(p.stat().st_size for p in DATA.glob("*/*.mcap")) < 1_100_000 * len(TAGS)  # small


@pytest.mark.parametrize("tag,name", FILES)
def test_it_replays_identical(tag, name):
    path = DATA / tag / f"{name}.mcap"
    done = replay_committed(path)
    assert done.returncode == 0 and done.stdout.startswith("identical"), \
        f"{done.stdout}{done.stderr}\n{path.name} of {tag} no longer replays: {REGENERATE}"


@pytest.mark.parametrize("tag,name", FILES)
def test_the_client_spoke_its_tags_protocol_and_the_robot_moved(tag, name):
    recording = open_recording(DATA / tag / f"{name}.mcap")
    expected = ({"hand": cpp.GRIPPER_PROTOCOL} if name == "grasp_object"
                else {"vacuum_gripper": cpp.VACUUM_GRIPPER_PROTOCOL} if name == "vacuum_object"
                else {"robot": cpp.PROTOCOL[tuple(map(int, tag.split(".")[:2]))]})
    assert connect_versions(recording) == expected
    assert all("command" in request for request in requests(recording))  # each one read
    CHECKS[name](recording, complete=name not in CUTS)


def test_a_replay_on_other_kernels_says_the_recording_does_not_name_its_own():
    """These files predate recordings that keep their numerical kernels: a replay on another
    OpenBLAS core diverges, and says why it may."""
    other = subprocess.run([sys.executable, "-m", "franka_sim", "replay",
                            str(DATA / "0.21.2" / "generate_joint_position_motion.mcap")],
                           capture_output=True, text=True, timeout=300,
                           env={**os.environ, "OPENBLAS_CORETYPE": "Prescott"})
    lines = other.stdout.splitlines()
    assert other.returncode == 1 and lines[0].startswith("diverged at cycle ")
    assert lines[1].startswith("the recording does not say which numerical kernels it ran on")
