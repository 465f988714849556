"""A world of several arms that cannot be served says so on one line, naming the arm and the
problem, exits non-zero, and serves nothing half-way."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from franka_sim.testing import fresh_loopback_address


def serve(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "franka_sim", "serve", *args],
                          capture_output=True, text=True, timeout=60)


def said(done: subprocess.CompletedProcess) -> str:
    """What the failed start said, as one line."""
    assert done.returncode != 0
    assert "Traceback" not in done.stderr
    return " ".join(done.stderr.replace("│", " ").split())


def test_two_arms_on_one_address():
    host = fresh_loopback_address()
    err = said(serve("--arm", f"left={host}", "--arm", f"right={host}"))
    assert f"arm right: {host} serves arm left already" in err


def test_an_arm_named_as_the_mobile_base():
    """Its log lines and its recording's channels would be the base's (a recording that then
    does not replay)."""
    a, b, c = (fresh_loopback_address() for _ in range(3))
    err = said(serve("--scene", "mobile_duo", "--arm", f"base={a}", "--arm", f"right={b}",
                     "--mobile-base", c))
    assert "arm base: the mobile base's name" in err


def test_an_address_that_cannot_be_bound_names_the_arm_and_serves_nothing():
    left, right = fresh_loopback_address(), fresh_loopback_address()
    with socket.socket() as taken:
        taken.bind((right, 1338))  # the right arm's Hand port
        taken.listen()
        done = serve("--arm", f"left={left}", "--arm", f"right={right}", "--scene",
                     "dual_arm_table")
        err = said(done)
        assert f"arm right: {right}:1338 (Franka Hand) is already in use" in err
    with socket.socket() as probe:  # the left arm, opened first, was closed again
        probe.bind((left, 1337))


def test_an_address_not_on_this_machine():
    err = said(serve("--arm", "left=192.0.2.7", "--arm", f"right={fresh_loopback_address()}",
                     "--scene", "dual_arm_table"))
    assert "arm left: 192.0.2.7:1337 cannot be served" in err


def test_an_unknown_scene_name():
    err = said(serve("--scene", "no_such_scene"))
    assert "unknown scene 'no_such_scene'" in err and "dual_arm_table" in err


@pytest.mark.parametrize("spec, problem", [
    ("left", "expected NAME[:ROBOT][+TOOL]=ADDRESS"),
    ("left:ur5=127.0.0.5", "'ur5' is not a robot (fr3, fer)"),
    ("left+screwdriver=127.0.0.5", "'screwdriver' is not a tool (hand, vacuum, none)"),
    ("left=localhost", "is not an IP address"),
    ("left=127.0.0.5@1,2", "3 or 4 finite numbers"),
    ("left=127.0.0.5@1,x,2", "in numbers"),
    ("a/b=127.0.0.5", "no '/'"),
    ("left=127.0.0.5@1e9,0,0", "its base (1000000000.0, 0.0, 0.0) is over 100 m from the "
     "world's origin"),
])
def test_a_malformed_arm(spec, problem):
    assert problem in said(serve("--arm", spec))


def test_an_unknown_robot():
    err = said(serve("--robot", "ur5"))
    assert "--robot" in err and "'ur5' is not one of" in err


def test_arms_placed_into_each_other():
    left, right = fresh_loopback_address(), fresh_loopback_address()
    err = said(serve("--arm", f"left={left}@0,0.05,0", "--arm", f"right={right}@0,-0.05,0"))
    assert "arm left: placed into arm right" in err


def test_an_arm_standing_inside_the_mobile_base_is_refused_by_its_name():
    arm, base = fresh_loopback_address(), fresh_loopback_address()
    err = said(serve("--arm", f"solo={arm}", "--mobile-base", base))  # no site: at its column
    assert "arm solo: at its starting pose it would be inside another body: link2 into " \
           "mobile_base" in err and "stand it elsewhere" in err


def test_a_host_given_beside_arms_is_said_to_serve_nothing():
    from franka_sim.testing import ServerProcess

    host, arm = fresh_loopback_address(), fresh_loopback_address()
    server = ServerProcess(host, "--arm", f"left={arm}").wait_ready()  # (it passes --host)
    try:
        assert server.log_matching(f"--host {host} serves nothing beside --arm")
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection((host, 1337), timeout=5).close()
    finally:
        server.stop()


def test_the_mobile_duo_without_its_base_says_the_arms_stand_in_the_air():
    from franka_sim.testing import ServerProcess

    left, right = fresh_loopback_address(), fresh_loopback_address()
    server = ServerProcess(left, "--scene", "mobile_duo", "--arm", f"left={left}",
                           "--arm", f"right={right}").wait_ready()
    try:
        said = server.wait_for_log("stands its arms on the mobile base's column")
        assert len(said) == 1 and "without --mobile-base ADDRESS" in said[0]
    finally:
        server.stop()


@pytest.mark.parametrize("arms, unplaced", [((), "fr3"), (("left", "middle"), "middle")])
def test_an_arm_a_scene_has_no_site_for_is_said_to_stand_at_the_origin(arms, unplaced):
    """A scene of arm sites with an arm named for none of them (one arm without --arm: `fr3`)
    serves it at the world origin, as docs/several_arms.md says, and says so at start."""
    from franka_sim.testing import ServerProcess

    host = fresh_loopback_address()
    flags = [flag for name in arms for flag in ("--arm", f"{name}={fresh_loopback_address()}")]
    server = ServerProcess(host, "--scene", "dual_arm_table", *flags).wait_ready()
    try:
        said = server.wait_for_log("stands at the world origin")
        assert len(said) == 1 and f"arm {unplaced}, named for none" in said[0]
        assert "arm/left, arm/right" in said[0]
    finally:
        server.stop()
    placed = ServerProcess(fresh_loopback_address(), "--scene", "dual_arm_table", "--arm",
                           f"left={fresh_loopback_address()}").wait_ready()
    placed.stop()  # (its start's lines all logged before it stops)
    assert not placed.log_matching("origin")
