"""A recorded pylibfranka session: the file, what it holds, and its replay (bit for bit)."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import numpy as np
import pytest
from mcap.reader import make_reader

from franka_sim.protocol.codec import COMMAND_DTYPE
from franka_sim.protocol.gripper_messages import GripperState
from franka_sim.recording import FORMAT_VERSION
from franka_sim.recording.channels import COMMAND_PREFIX
from franka_sim.recording.reader import open_recording
from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.clients import connect, move_to
from support.replayed import identical_line

RUNS = ["lockstep_run", "realtime_run"]


def franka_sim(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "franka_sim", *args], capture_output=True,
                          text=True, timeout=300, env=env)


@pytest.mark.parametrize("run", RUNS)
def test_the_file_opens_with_mcaps_reader_and_holds_every_channel(run, request):
    path, _ = request.getfixturevalue(run)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        counts = {summary.channels[c].topic: n
                  for c, n in summary.statistics.channel_message_counts.items()}
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert counts["/fr3/robot_state"] > 1000 and counts["/fr3/command"] > 500
    assert counts["/fr3/tcp"] >= 8 and counts["/fr3/reply"] >= 6
    assert counts["/fr3/gripper_state"] > 0 and counts["/fr3/control"] == 2  # place, push
    assert counts["/world/bodies"] > 100 and counts["/log"] > 0
    assert metadata["franka-sim"]["format_version"] == str(FORMAT_VERSION)
    assert len(metadata["franka-sim"]["urdf_sha256"]) == 64


@pytest.mark.parametrize("run", RUNS)
def test_every_published_cycle_once_and_what_the_client_read(run, request):
    path, seen = request.getfixturevalue(run)
    recording = open_recording(path)
    states = recording.states()
    ids = states["message_id"].astype(np.int64)
    assert np.all(np.diff(ids) > 0)  # each published cycle once, in order
    by_id = {int(n): s for n, s in zip(ids, states)}
    for message_id, q, dq, tau_J, mode in seen:
        state = by_id[message_id]
        assert np.array_equal(state["q"], q) and np.array_equal(state["dq"], dq)
        assert np.array_equal(state["tau_J"], tau_J) and int(state["robot_mode"]) == mode
    modes = set(states["robot_mode"].tolist())
    assert {1, 2, 4} <= modes  # Idle, Move, Reflex
    tcp = [e.json() for e in recording.of("tcp")]
    commands = {r["command"] for e in tcp for r in e["requests"]}
    assert {"Connect", "Move", "AutomaticErrorRecovery"} <= commands  # robot
    assert {"Move"} <= {r["command"] for e in tcp if e["service"] == "hand"
                        for r in e["requests"]}


@pytest.mark.parametrize("run", RUNS)
def test_replay_is_identical(run, request, tmp_path):
    path, _ = request.getfixturevalue(run)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    done = franka_sim("replay", str(path), env={**os.environ, "TMPDIR": str(tmp)})
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.strip() == identical_line(open_recording(path))
    assert done.stderr == ""  # (the run's warnings, its reflex's, are the recording's, not said)
    assert list(tmp.iterdir()) == []  # the replay's own files are gone with it


def test_replay_until_compares_up_to_that_cycle(lockstep_run):
    path, _ = lockstep_run
    ids = open_recording(path).states()["message_id"]
    until = int(ids[len(ids) // 2])
    done = franka_sim("replay", str(path), "--until", str(until))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == identical_line(open_recording(path), until)


def _with_one_message_changed(source, target, topic: str, nth: int, change) -> bytes:
    """Copy `source` with the `nth` message on `topic` replaced by `change(data)`; the new
    bytes."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(source, "rb") as f, open(target, "wb") as out:
        reader = make_reader(f)
        writer = Writer(out)
        writer.start()
        for m in reader.iter_metadata():
            writer.add_metadata(m.name, m.metadata)
        schemas, channels, changed = {}, {}, None
        seen = 0
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id])
            data = message.data
            if channel.topic == topic:
                seen += 1
                if seen == nth:
                    data = changed = change(data)
            writer.add_message(channels[channel.id], message.log_time, data,
                               message.publish_time, message.sequence)
        writer.finish()
    assert changed is not None, f"fewer than {nth} messages on {topic}"
    return changed


def _with_one_command_changed(source, target) -> int:
    """Copy `source` with one mid-motion command's q_c changed; the cycle it answered."""
    def change(data: bytes) -> bytes:
        command = np.frombuffer(data[COMMAND_PREFIX.size:], COMMAND_DTYPE)[0].copy()
        command["q_c"][0] += 1e-4
        return data[:COMMAND_PREFIX.size] + command.tobytes()
    changed = _with_one_message_changed(source, target, "/fr3/command", 200, change)
    return COMMAND_PREFIX.unpack_from(changed)[0]


def test_one_command_changed_names_the_first_divergent_cycle_and_field(lockstep_run, tmp_path):
    path, _ = lockstep_run
    changed = _with_one_command_changed(path, tmp_path / "changed.mcap")
    done = franka_sim("replay", str(tmp_path / "changed.mcap"))
    assert done.returncode == 1
    line = done.stdout.strip()
    # The command answered cycle `changed`; the next cycle's state shows it first (q_d).
    assert line.startswith(f"diverged at cycle {changed + 1}: "), line
    assert "q_d" in line.split(": ", 1)[1].split(", "), line


def test_a_hand_state_changed_names_its_cycle_and_field(lockstep_run, tmp_path):
    path, _ = lockstep_run
    def change(data: bytes) -> bytes:
        state = GripperState.parse(data)
        state.width += 1e-6
        return GripperState.build(state)
    changed = _with_one_message_changed(path, tmp_path / "changed.mcap", "/fr3/gripper_state",
                                        2, change)
    done = franka_sim("replay", str(tmp_path / "changed.mcap"))
    assert done.returncode == 1
    assert done.stdout.strip() == (f"diverged at cycle {GripperState.parse(changed).message_id}:"
                                   " width (gripper_state of robot fr3)")


@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS's Prescott core is x86's")
def test_a_recording_made_with_other_kernels_diverges_and_replay_says_why(tmp_path):
    """OpenBLAS's core picked by OPENBLAS_CORETYPE: a product's last bits differ, a replay
    elsewhere diverges, and replay says the kernels differed; with the recorder's, identical."""
    own = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}  # the CPU's pick
    core = subprocess.run([sys.executable, "-c", "from franka_sim.recording.numerics import "
                           "numerics; print(numerics()['openblas_core'])"], env=own,
                          capture_output=True, text=True, timeout=60).stdout.strip()
    if core in ("", "Katmai", "Prescott"):
        pytest.skip(f"this machine's own OpenBLAS core ({core or 'none'}) is the recorder's")
    path, host = tmp_path / "prescott.mcap", fresh_loopback_address()
    server = ServerProcess(host, "--clock", "lockstep", "--record", str(path),
                           env={"OPENBLAS_CORETYPE": "Prescott"}).wait_ready()
    try:
        robot = connect(host)
        q0 = np.array(robot.read_once().q)
        move_to(robot, q0 + np.array([0.3, 0.2, 0, -0.2, 0, 0.2, 0.3]), 0.5)
        del robot
    finally:
        server.stop()
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)], env=own,
                          capture_output=True, text=True, timeout=300)
    said = done.stdout.strip().splitlines()
    assert done.returncode == 1 and said[0].startswith("diverged at cycle"), done.stdout
    assert said[1].startswith(f"recorded with other numerical kernels (openblas_core Katmai → "
                              f"{core}"), said
    same = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          env={**own, "OPENBLAS_CORETYPE": "Prescott"}, capture_output=True,
                          text=True, timeout=300)
    assert same.returncode == 0 and same.stdout.startswith("identical"), same.stdout
