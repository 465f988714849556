"""Is the simulator ready? What `franka-sim check` asks, through the control API's /health or,
with `fci`, through a real v10 handshake. Each attempt yields None (ready) or one line saying
why not, so that a health check's log says what to fix. A simulator that stopped simulating
will not become ready: that answer ends the wait at once."""

from __future__ import annotations

import time


def health_problem(host: str, control_port: int = 1340, token: str | None = None,
                   timeout: float = 2.0) -> str | None:
    from franka_sim.control import Control, ControlError, Failed, Unauthorized, Unreachable

    where = f"{host}:{control_port}"
    try:
        health = Control(host, port=control_port, token=token, timeout=timeout).health()
    except Failed as exc:
        raise NeverReady(f"{where}: {exc.message}") from None
    except Unauthorized as exc:
        return (f"{where}: unauthorized ({exc.message}); pass the server's --control-token "
                "as --token")
    except Unreachable as exc:
        said = exc.message.lower()
        if "refused" in said:
            return f"{where}: connection refused (no simulator's control API there)"
        if "timed out" in said:
            return f"{where}: timeout, no answer within {timeout:g} s"
        return f"{where}: unreachable ({exc.message})"
    except ControlError as exc:
        return f"{where}: {exc}"
    if not health.get("ready"):
        return f"{where}: not ready (robot mode {health.get('robot_mode', '?')})"
    return None


class NeverReady(Exception):
    """The simulator answered that it stopped simulating: waiting longer cannot help."""


def fci_problem(host: str, timeout: float = 2.0) -> str | None:
    from franka_sim.fci_probe import ProbeFailed, probe_fci

    try:
        probe_fci(host, timeout=timeout)
    except ProbeFailed as exc:
        return str(exc)
    return None


def check_until(host: str, *, wait: float = 0.0, timeout: float = 2.0, fci: bool = False,
                control_port: int = 1340, token: str | None = None,
                interval: float = 0.2) -> str | None:
    """None once ready; the last attempt's reason when `wait` seconds passed without."""
    end = time.monotonic() + wait
    while True:
        try:
            reason = (fci_problem(host, timeout) if fci else
                      health_problem(host, control_port, token, timeout))
        except NeverReady as final:
            return str(final)
        left = end - time.monotonic()
        if reason is None or left <= 0:
            return reason
        time.sleep(min(interval, left))
