"""A recording started and finished through the control API on a running server (what the
pytest plugin records each test with): it begins from a reset world at a late message_id, and
its replay in a fresh simulator is identical all the same."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pylibfranka
import pytest

from franka_sim.control import BadRequest, Conflict, Control, ControlError
from franka_sim.recording.reader import open_recording
from franka_sim.testing import ServerProcess, fresh_loopback_address, running_sim
from support.clients import connect, move_to
from support.replayed import identical_line


def _replay(path) -> str:
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout.strip()


def _client_gone(control: Control) -> None:
    end = time.monotonic() + 5
    while control.health()["client_connected"]:
        assert time.monotonic() < end, "the client did not leave"
        time.sleep(0.01)


def _busy_client(host: str, control: Control) -> None:
    """What an earlier test leaves: the arm moved, settings changed, the Hand closed, the cube
    moved."""
    robot = connect(host)
    robot.set_collision_behavior([30.0] * 7, [30.0] * 7, [30.0] * 6, [30.0] * 6)
    robot.set_load(0.5, [0.0, 0.0, 0.05], [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3])
    q0 = np.array(robot.read_once().q)
    move_to(robot, q0 + np.array([0.2, 0.1, 0, -0.2, 0, 0.2, 0.1]), 0.4)
    gripper = pylibfranka.Gripper(host)
    assert gripper.move(0.02, 0.1)
    del gripper
    control.set_pose("cube", [0.5, -0.1, 0.3])
    del robot
    _client_gone(control)


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_a_recording_started_on_a_running_server_replays_identical(clock, tmp_path):
    path = tmp_path / "test.mcap"
    with running_sim("--clock", clock, "--enforce-motion-limits") as sim:
        control = Control(sim.host)
        _busy_client(sim.host, control)
        control.reset()
        started = control.start_recording(path)
        assert started["path"] == str(path) and started["cycle"] > 400
        robot = connect(sim.host)
        q0 = np.array(robot.read_once().q)
        move_to(robot, q0 + np.array([0, 0.1, 0, -0.1, 0, 0, 0]), 0.3)
        robot.read_once()
        control.set_pose("cube", [0.45, 0.1, 0.3])
        gripper = pylibfranka.Gripper(sim.host)
        assert gripper.move(0.06, 0.1)
        del gripper, robot
        finished = control.finish_recording()
        assert finished["path"] == str(path) and finished["dropped"] == 0
        with pytest.raises(Conflict, match="no recording"):
            control.finish_recording()
    states = open_recording(path).states()
    assert int(states["message_id"][0]) > started["cycle"]
    assert _replay(path) == identical_line(open_recording(path))


def test_what_a_recording_start_refuses(tmp_path):
    with running_sim() as sim:
        control = Control(sim.host)
        with pytest.raises(BadRequest, match="cannot record to"):
            control.start_recording(tmp_path / "missing" / "x.mcap")
        with pytest.raises(BadRequest, match="No space left on device"):
            control.start_recording("/dev/full")  # (it opens; it takes no byte)
        with pytest.raises(BadRequest, match="embedded null"):
            control.start_recording(f"{tmp_path}/x\0y.mcap")
        robot = connect(sim.host)
        robot.read_once()
        with pytest.raises(Conflict, match="FCI client connected"):
            control.start_recording(tmp_path / "a.mcap")
        assert not (tmp_path / "a.mcap").exists()
        del robot
        _client_gone(control)
        control.start_recording(tmp_path / "b.mcap")
        with pytest.raises(Conflict, match="already recording"):
            control.start_recording(tmp_path / "b.mcap")
        control.finish_recording()
        assert len(open_recording(tmp_path / "b.mcap").of("control")) == 1  # its reset


def test_a_recording_under_way_is_finished_when_the_server_stops(tmp_path):
    with running_sim() as sim:
        Control(sim.host).start_recording(tmp_path / "c.mcap")
        connect(sim.host).read_once()
    assert _replay(tmp_path / "c.mcap").startswith("identical")


def test_a_served_recording_refuses_a_second(tmp_path):
    with running_sim("--record", str(tmp_path / "run.mcap")) as sim:
        with pytest.raises(Conflict, match="already recording"):
            Control(sim.host).start_recording(tmp_path / "d.mcap")
        with pytest.raises(Conflict, match="no recording started through the control API"):
            Control(sim.host).finish_recording()


def test_a_write_that_fails_stops_the_recording_with_one_line_and_the_robot_serves_on(tmp_path):
    """Files over 256 KiB refused to the server (RLIMIT_FSIZE: "File too large", as a full disk
    refuses them): the recording stops where the write failed, said once; the motion goes on."""
    host = fresh_loopback_address()
    limited = ("import os, resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, "
               "(1 << 18, 1 << 18)); os.execv(sys.executable, [sys.executable, '-P', '-m', "
               "'franka_sim', 'serve', *sys.argv[1:]])")
    server = ServerProcess(host, command=[sys.executable, "-c", limited, "--host", host,
                                          "--clock", "lockstep"]).wait_ready()
    try:
        control = Control(host)
        control.start_recording(tmp_path / "big.mcap")
        robot = connect(host)
        q0 = np.array(robot.read_once().q)
        target = q0 + np.array([0.3, 0, 0, 0, 0, 0, 0.3])
        np.testing.assert_allclose(move_to(robot, target, 2.0), target, atol=1e-2)
        stopped = server.wait_for_log("stopped: File too large")
        assert len(stopped) == 1 and "the file keeps what reached it" in stopped[0]
        assert f"recording to {tmp_path / 'big.mcap'} stopped" in stopped[0]  # (its path)
        del robot
        _client_gone(control)
        with pytest.raises(ControlError, match="stopped when a write failed") as failed:
            control.finish_recording()
        assert failed.value.status == 500
        control.start_recording(tmp_path / "next.mcap")  # nothing of the failed one is left
        control.finish_recording()
        assert not any("Traceback" in line for line in server.sync())
    finally:
        assert server.stop() < 10
    assert server.proc.returncode == 0
    assert (tmp_path / "big.mcap").stat().st_size <= 1 << 18


def test_a_recording_that_replaces_a_file_says_so(tmp_path):
    """A container restarted with the same --record writes over the last run's file: said."""
    path = tmp_path / "run.mcap"
    path.write_bytes(b"x" * 1000)
    with running_sim("--record", str(path)) as sim:
        assert sim.wait_for_log(f"recording to {path} replaces the 1000-byte file")
    with running_sim("--record", str(tmp_path / "new.mcap")) as sim:
        assert not sim.log_matching("-byte file that was there")


def test_a_start_that_fails_or_never_comes_leaves_the_last_runs_file(tmp_path):
    """The file that was there stays until the recording starts: a start refused (its
    address in use) or an embedded simulator made and dropped leave it byte for byte, and no
    temporary beside it."""
    import gc

    from franka_sim import FrankaSim

    path = tmp_path / "run.mcap"
    last_run = b"the last run's recording" * 100
    path.write_bytes(last_run)
    with running_sim("--control-port", "0") as sim:
        done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host", sim.host,
                               "--record", str(path)], capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 1 and "in use" in done.stderr, done.stderr
    assert path.read_bytes() == last_run
    dropped = FrankaSim(host=fresh_loopback_address(), record=str(path))
    del dropped
    gc.collect()
    assert path.read_bytes() == last_run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


def test_an_embedder_records_to_a_path_and_replays_it(tmp_path):
    """`await sim.start_recording(Path)`, as Config.record takes one."""
    import asyncio

    from franka_sim import FrankaSim

    path = tmp_path / "embedded.mcap"

    async def app():
        async with FrankaSim(host=fresh_loopback_address(), control_port=0,
                             clock="lockstep") as sim:
            assert (await sim.start_recording(path))["path"] == str(path)
            await sim.set_pose("cube", [0.45, 0.1, 0.2])
            return await sim.finish_recording()

    assert asyncio.run(app())["path"] == str(path)
    assert _replay(path).startswith("identical")


def test_a_serve_record_that_failed_makes_way_for_one_through_the_control_api(tmp_path):
    """--record stopped by its disk (failure as the writer sets it on ENOSPC): the control API
    records again rather than answering 409 for a recording that no longer records."""
    import asyncio
    import errno

    from franka_sim import FrankaSim

    async def app():
        async with FrankaSim(host=fresh_loopback_address(), control_port=0, clock="lockstep",
                             record=tmp_path / "full.mcap") as sim:
            sim.recorder._writer.failure = OSError(errno.ENOSPC, "No space left on device")
            started = await sim.start_recording(tmp_path / "next.mcap")
            await sim.set_pose("cube", [0.45, 0.1, 0.2])
            return started, await sim.finish_recording()

    started, finished = asyncio.run(app())
    assert started["path"] == finished["path"] == str(tmp_path / "next.mcap")
    assert _replay(tmp_path / "next.mcap").startswith("identical")
