"""Where the control API is served: its port, its token, switched off, and embedded."""

from __future__ import annotations

import asyncio
import http.client
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim import FrankaSim
from franka_sim.config import READY_POSE
from franka_sim.control import BadRequest, Conflict, Control, NotFound, Unauthorized, Unreachable
from franka_sim.testing import fresh_loopback_address, running_sim


def test_a_token_is_required_on_every_resource_and_never_shown_on_the_command_line():
    with running_sim("--control-token", "s3cret") as sim:
        for control in (Control(sim.host), Control(sim.host, token="wrong")):
            for call in (control.health, control.state, control.bodies, control.reset,
                         lambda: control.pose("cube"), lambda: control.push("hand", [1, 0, 0])):
                with pytest.raises(Unauthorized) as refused:
                    call()
                assert refused.value.status == 401
        assert "wrong bearer token" in sim.log_matching("refused (401)")[-1]
        assert Control(sim.host, token="s3cret").health()["ready"] is True
        # The scheme's name in any case (RFC 9110); another scheme is said to be one.
        for header, status in (("bearer s3cret", 200), ("BEARER  s3cret", 200),
                               ("Basic s3cret", 401), ("s3cret", 401)):
            connection = http.client.HTTPConnection(sim.host, 1340, timeout=10)
            connection.request("GET", "/health", headers={"Authorization": header})
            assert connection.getresponse().status == status, header
            connection.close()
        assert "not a bearer token" in sim.log_matching("refused (401)")[-1]
        cmdline = Path(f"/proc/{sim.pid}/cmdline").read_bytes()
        assert b"s3cret" not in cmdline
        # what `ps` shows is still the command given (`pgrep -f "franka-sim serve"` finds it)
        assert b"\0franka-sim\0serve\0" in cmdline and b"--control-token\0***" in cmdline


def test_a_token_beyond_ascii_works_from_the_client_and_latin_1_bytes_are_unauthorized():
    """The token as UTF-8, as curl sends it; the Python client sends it so too (http.client
    alone would send Latin-1, or refuse what Latin-1 lacks). Bytes that are not UTF-8 are a
    wrong token (401), not a failure of the server."""
    with running_sim("--control-token", "clé-ключ") as sim:
        assert Control(sim.host, token="clé-ключ").health()["ready"] is True
        connection = http.client.HTTPConnection(sim.host, 1340, timeout=10)
        connection.putrequest("GET", "/health")
        connection.putheader("Authorization", b"Bearer cl\xe9")  # (Latin-1)
        connection.endheaders()
        assert connection.getresponse().status == 401
        connection.close()
        assert "wrong bearer token" in sim.log_matching("refused (401)")[-1]
    for token in ("a\r\nX-Injected: 1", "", " padded "):
        with pytest.raises(ValueError, match="token must be"):
            Control("127.0.0.1", token=token)
    with pytest.raises(TypeError, match="cannot be sent as JSON"):  # a set has no order
        Control("127.0.0.1").set_pose("cube", {0.45, 0.0, 0.3})


def test_port_and_token_from_the_environment():
    env = {"FRANKA_SIM_CONTROL_PORT": "1345", "FRANKA_SIM_CONTROL_TOKEN": "t0ken"}
    with running_sim(env=env) as sim:
        assert Control(sim.host, 1345, token="t0ken").state()["robot_mode"] == "Idle"
        with pytest.raises(Unreachable):
            Control(sim.host, timeout=2).health()  # not on 1340


def test_port_0_serves_no_control_api():
    with running_sim("--control-port", "0") as sim:
        assert sim.log_matching("no control API")
        with pytest.raises(Unreachable, match=f"{sim.host}:1340"):
            Control(sim.host, timeout=2).health()


@pytest.mark.parametrize("port", ["1337", "1338", "1339"])
def test_the_fci_and_gripper_ports_are_refused(port):
    done = subprocess.run(
        [sys.executable, "-m", "franka_sim", "serve", "--host", fresh_loopback_address(),
         "--control-port", port], capture_output=True, text=True, timeout=60,
        env={**os.environ, "COLUMNS": "300"})
    assert done.returncode == 2
    assert f"{port} is the FCI's, the Hand's or the vacuum gripper's port" in done.stderr


def test_embedded_the_operations_are_async_methods_with_the_same_errors():
    host = fresh_loopback_address()

    async def app():
        async with FrankaSim(host=host, control_port=0) as sim:
            assert (await sim.health())["robot_mode"] == "Idle"
            await sim.reset(q=[0.1, -0.5, 0.0, -2.0, 0.0, 1.5, 0.5])
            assert (await sim.state())["q"][0] == 0.1
            placed = await sim.set_pose("cube", [0.4, 0.1, 0.3])
            assert placed["position"] == [0.4, 0.1, 0.3]
            assert (await sim.pose("scene/cube"))["free"] is True
            assert "hand" in [body["name"] for body in await sim.bodies()]
            assert (await sim.push("hand", [0.0, 0.0, 5.0], duration=0.02))["cycles"] == 20
            with pytest.raises(NotFound):
                await sim.pose("link9")
            with pytest.raises(Conflict):
                await sim.set_pose("hand", [0.0, 0.0, 0.0])
            with pytest.raises(BadRequest):
                await sim.push("hand", [np.nan, 0.0, 0.0])
            await sim.reset()
            return (await sim.state())["q"]

    assert asyncio.run(app()) == list(READY_POSE)


def test_embedded_the_http_server_stops_with_the_simulator():
    host = fresh_loopback_address()

    async def app():
        async with FrankaSim(host=host) as sim:
            health = await asyncio.to_thread(Control(host).health)
            assert health["ready"] and sim.config.control_port == 1340
        return asyncio.all_tasks()

    assert len(asyncio.run(app())) == 1  # only app() itself: nothing left running
    with pytest.raises(Unreachable):
        Control(host, timeout=2).health()


def test_a_taken_control_port_is_said_on_one_line():
    import socket

    host = fresh_loopback_address()
    with socket.socket() as taken:
        taken.bind((host, 1340))
        taken.listen()
        done = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host", host],
                              capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    assert f"{host}:1340 (control API) is already in use" in done.stderr
    assert "Traceback" not in done.stderr
