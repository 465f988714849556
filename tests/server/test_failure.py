"""A simulator that stopped simulating says so: its cycle fails (here on purpose), and then
/health answers 503 with the reason, `franka-sim check` exits 1 at once, an embedded
FrankaSim sets `failed`, and a `franka-sim serve` process logs why and exits non-zero."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from pathlib import Path

import pytest

from franka_sim import FrankaSim
from franka_sim.config import ArmSpec, Config
from franka_sim.control import Control, Failed
from franka_sim.serving import serving_argument
from franka_sim.testing import fresh_loopback_address

FAILING_SERVE = Path(__file__).resolve().parents[1] / "support" / "failing_serve.py"


def _boom(*args):
    raise RuntimeError("injected failure")


def test_an_embedded_simulator_whose_cycle_fails_reports_it():
    host = fresh_loopback_address()

    async def scenario() -> tuple:
        async with FrankaSim(host=host) as sim:
            assert (await sim.health())["ready"]
            await sim.worker.call(lambda physics: setattr(sim.driver.cycle, "release", _boom))
            await asyncio.wait_for(sim.failed.wait(), 30)
            with pytest.raises(Failed, match="injected failure"):
                await sim.health()
            over_http = await asyncio.to_thread(_http_health, host)
            started = time.monotonic()
            check = await asyncio.create_subprocess_exec(
                sys.executable, "-m", "franka_sim", "check", host, "--wait", "60",
                stderr=subprocess.PIPE)
            _, err = await check.communicate()
            return sim.failure, over_http, check.returncode, err.decode(), \
                time.monotonic() - started

    failure, over_http, returncode, said, took = asyncio.run(scenario())
    assert "RuntimeError: injected failure" in failure
    assert over_http.status == 503 and "injected failure" in over_http.message
    assert returncode == 1 and "injected failure" in said
    assert took < 60  # it did not wait for a readiness that cannot come


def _http_health(host: str) -> Failed:
    with pytest.raises(Failed) as refused:
        Control(host).health()
    return refused.value


@pytest.mark.parametrize("world", [(), ("--scene", "mobile_duo", "--mobile-base", "B")])
def test_a_serve_process_whose_cycle_fails_exits_non_zero_and_says_why(world):
    host = fresh_loopback_address()
    config = Config(host=host)
    if world:
        config = Config(scene="mobile_duo", mobile_base=fresh_loopback_address(),
                        arms=(ArmSpec("left", host), ArmSpec("right", fresh_loopback_address())))
    proc = subprocess.run([sys.executable, str(FAILING_SERVE), serving_argument(config)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1, proc.stderr
    assert "the cycle failed" in proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("franka-sim: the simulator stopped simulating: the cycle failed: "
                           "RuntimeError: injected failure"), proc.stderr
