"""pylibfranka behind an address translation, on loopback: the TCP connection comes from one
address, the client's UDP answers from another.

That is what a client on the host meets when it connects to the host's own address of a
container published with Docker's userland proxy (`docker run -p 1337:1337 …`): the server
sees the TCP peer as that address, while libfranka answers the states to wherever they came
from, from its route's source address. A TCP proxy (support/tcp_proxy.py, as Docker's) connects
on to the server from an address of its own; the client's UDP socket, bound to every address,
still gets the states sent there, and answers from 127.0.0.1. A joint motion must run to its
end, and the server say once where the answers come from.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.testing import fresh_loopback_address, running_sim
from support.tcp_proxy import tcp_proxy

ARM_PROGRAM = Path(__file__).resolve().parents[1] / "support" / "arm_program.py"
DELTA = [0, 0, 0, 0, 0, 0, 0.1]
# Not a measure of speed: the bound on a client left hanging (a motion of 0.5 s takes about a
# second here), so that a server dropping the answers fails the test instead of blocking it.
HANG = 60


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
def test_a_joint_motion_runs_when_the_answers_come_from_another_address(clock):
    front, via = fresh_loopback_address(), fresh_loopback_address()
    with running_sim("--clock", clock) as sim, tcp_proxy(front, (sim.host, 1337), via):
        program = subprocess.Popen(
            [sys.executable, str(ARM_PROGRAM), front, json.dumps(DELTA), "0.5"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            out, err = program.communicate(timeout=HANG)
        except subprocess.TimeoutExpired:
            program.kill()
            out, err = program.communicate()
            pytest.fail(f"the client hung (its answers dropped?)\n{out}{err}\n"
                        + "\n".join(sim.lines[-5:]))
        assert program.returncode == 0, out + err
        outcome = json.loads(out.strip().splitlines()[-1])
        moved = sim.log_matching("UDP commands of the client at")
        dropped = sim.log_matching("not the connected client")
    assert outcome["error"] == ""
    assert np.allclose(outcome["q"], outcome["target"], atol=2e-3)
    if clock == "lockstep":  # every answer on time, wherever it came from
        assert outcome["min_rate"] == 1.0
    assert len(moved) == 1, moved
    assert f"client at {via} come from 127.0.0.1:" in moved[0]
    assert dropped == []
