"""Each arm of a world of several serves its own control API: what it reads and resets is that
arm; the bodies, and pushes on them, are the world's."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from franka_sim.config import READY_POSE
from franka_sim.control import BadRequest, Control, NotFound
from clients.test_several_arms import PROGRAM, two_arms


def test_reset_acts_on_its_arm_only_and_bodies_are_shared():
    with two_arms() as (server, left, right):
        done = subprocess.run([sys.executable, str(PROGRAM), right, json.dumps([0.3] + [0] * 6),
                               "0.5"], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        moved = Control(right).state()["q"]
        assert moved[0] > 0.29
        Control(left).set_pose("scene/cube", [0.3, 0.0, 0.025])  # moved on the table
        Control(left).reset()  # the left arm only: the cube and the right arm stay
        assert Control(right).state()["q"] == moved
        np.testing.assert_allclose(Control(left).state()["q"], READY_POSE, atol=1e-12)
        np.testing.assert_allclose(Control(right).pose("scene/cube")["position"],
                                   [0.3, 0.0, 0.025], atol=1e-3)
        Control(right).reset()
        np.testing.assert_allclose(Control(right).state()["q"], READY_POSE, atol=1e-12)
        names = {b["name"] for b in Control(right).bodies()}
        assert {"left/hand", "right/hand", "scene/cube", "scene/box"} <= names
        assert names == {b["name"] for b in Control(left).bodies()}
        with pytest.raises(NotFound, match="did you mean 'left/link7' or 'right/link7'"):
            Control(left).push("link7", [10.0, 0.0, 0.0])  # (a link is its arm's)
        with pytest.raises(NotFound, match="did you mean 'left/link7' or 'right/link7'"):
            Control(left).pose("fr3_link7")
        assert Control(left).pose("left/fr3_link7") == Control(left).pose("left/link7")
        assert Control(left).health()["arm"] == "left"
        assert Control(right).health()["arm"] == "right"
        # Each line about one arm names it: its client, its requests, its cycles.
        assert server.log_matching(": right: FCI client") and not server.log_matching(
            ": left: FCI client")
        with pytest.raises(BadRequest):
            Control(left).set_pose("scene/cube", [0.3, 0.0])
        assert server.log_matching(": left: control API: PUT /bodies/scene/cube refused (400)")
        assert not server.log_matching(": right: control API")


def test_a_push_on_one_arm_is_felt_by_that_arm_only():
    # Realtime, to look while the push lasts (lockstep plays it out and settles at once).
    with two_arms(clock="realtime") as (server, left, right):
        Control(left).push("right/link7", force=[0, 0, -30], duration=1.0)
        time.sleep(0.3)
        right_q = np.array(Control(right).state()["q"])
        left_q = np.array(Control(left).state()["q"])
    assert np.abs(right_q - READY_POSE).max() > 1e-4  # the right arm gave way
    np.testing.assert_array_equal(left_q, READY_POSE)


def test_in_realtime_a_reset_of_one_arm_keeps_one_message_id_for_all(tmp_path):
    """A realtime world's idle cycle is released ahead; a reset takes it back. Every robot's
    clock goes back with it (the reset arm's alone did: each reset put the other arm's ids one
    ahead, and the recording no longer replayed)."""
    import pylibfranka

    from franka_sim.recording.reader import open_recording

    path = tmp_path / "run.mcap"
    with two_arms("--record", str(path), clock="realtime") as (server, left, right):
        robots = [pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
                  for host in (left, right)]
        for _ in range(3):
            Control(left).reset()
        for robot in robots:
            robot.read_once()
        del robots
    recording = open_recording(path)
    # A world cycle's states are written one after the other, left's then right's (each
    # robot's while its client is connected).
    states = [e for e in recording.entries if e.key == "robot_state"]
    pairs = [(int.from_bytes(a.data[:8], "little"), int.from_bytes(b.data[:8], "little"))
             for a, b in zip(states, states[1:])
             if (a.robot, b.robot) == (0, 1) and b.wall - a.wall < 500_000]
    assert len(pairs) > 10 and all(left == right for left, right in pairs), pairs
    done = subprocess.run([sys.executable, "-m", "franka_sim", "replay", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.stdout.startswith("identical"), done.stdout + done.stderr


def test_each_line_about_an_arm_of_several_names_it_once():
    """The Desk locking an arm's brakes mid-motion (through its control API, in the cycle
    thread), a stranger's datagram to its UDP port (read in the cycle thread) and a refused
    TLS handshake at its Desk: each line names the arm, once."""
    import socket

    from clients.test_several_arms import start

    with two_arms("--desk-port", "8443") as (server, left, right):
        program = start(left, [0.3] + [0] * 6, 5.0)
        try:
            deadline = time.monotonic() + 60
            while Control(left).state()["robot_mode"] != "Move":
                assert time.monotonic() < deadline and program.poll() is None
                time.sleep(0.05)
            local = socket.inet_aton(left)[::-1].hex().upper()  # (its UDP port: read mid-motion)
            for row in open("/proc/net/udp").read().splitlines()[1:]:
                address, port = row.split()[1].split(":")
                if address == local:
                    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
                        stranger.sendto(b"x" * 10, (left, int(port, 16)))
            deadline = time.monotonic() + 10
            while not server.log_matching("dropped UDP datagram from"):
                assert time.monotonic() < deadline, "the stranger's datagram"
                time.sleep(0.05)
            Control(left).desk_arm(brakes="Locked")
            program.communicate(timeout=60)
        finally:
            program.kill()
        with socket.create_connection((left, 8443), timeout=10) as plain:
            plain.sendall(b"GET / HTTP/1.1\r\n\r\n")  # (no TLS: its handshake is refused)
            plain.recv(100)
        for said in ("Move aborted: the Desk locked the brakes", "dropped UDP datagram from",
                     "Desk: TLS handshake refused"):
            deadline = time.monotonic() + 10
            while not server.log_matching(said):
                assert time.monotonic() < deadline, said
                time.sleep(0.05)
            (line,) = server.log_matching(said)[:1]
            assert f": left: {said}" in line and line.count("left") == 1, line
