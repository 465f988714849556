"""The live status line of `franka-sim serve` on a terminal: client, robot mode, cycle rate,
success rate, last error; rewritten in place twice a second. Nothing when stdout is not a
terminal (a service's log stays clean). It reads a few attributes on the loop; no job, no lock."""

from __future__ import annotations

import asyncio
import sys
import time

import numpy as np

from franka_sim.protocol.errors import ERROR_NAMES

PERIOD = 0.5  # s between two updates


def status_text(*, client: bool, mode: str, rate: float, success: float, error: str) -> str:
    return (f"client {'connected' if client else 'none':9}  mode {mode:22}  "
            f"{rate:6.0f} cycles/s  success {success:5.1%}  last error: {error or '-'}")


async def show_status(sim, stream=None) -> None:
    """Until cancelled: the status line on `stream` (stdout) if it is a terminal."""
    stream = stream or sys.stdout
    if not stream.isatty():
        return
    core = sim.core
    last_error = ""
    cycle, at = core.message_id, time.monotonic()
    try:
        while True:
            await asyncio.sleep(PERIOD)
            now, n = time.monotonic(), core.message_id
            rate = (n - cycle) / (now - at) if now > at else 0.0
            cycle, at = n, now
            errors = np.flatnonzero(core.status.errors)
            if len(errors):
                last_error = ", ".join(ERROR_NAMES[i] for i in errors)
            health = sim.control.health()
            line = status_text(client=health["client_connected"], mode=health["robot_mode"],
                               rate=rate, success=float(core.success_rate), error=last_error)
            stream.write("\r\x1b[K" + line)
            stream.flush()
    finally:
        stream.write("\n")
        stream.flush()
