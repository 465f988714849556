"""Is the simulator ready? What `franka-sim check` asks, through the control API's /health or,
with `fci`, through a real v10 handshake; of one address, or of every robot a serving file
lists (server/serving_file.py: what a health check cannot learn from `serve`'s flags). Each
attempt yields None (ready) or one line saying why not, so that a health check's log says what
to fix. A simulator that stopped simulating
will not become ready: that answer ends the wait at once."""

from __future__ import annotations

import time
from pathlib import Path


def health_problem(host: str, control_port: int = 1340, token: str | None = None,
                   timeout: float = 2.0) -> str | None:
    from franka_sim.control import Control, ControlError, Failed, Unauthorized, Unreachable

    where = f"{host}:{control_port}"
    try:
        health = Control(host, port=control_port, token=token, timeout=timeout).health()
    except Failed as exc:
        raise NeverReady(f"{where}: {exc.message}") from None
    except Unauthorized as exc:  # (no wait will mend a wrong token: said at once)
        raise NeverReady(f"{where}: unauthorized ({exc.message}); pass the server's "
                         "--control-token as --token") from None
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


def serving_problem(path: Path, *, token: str | None = None, timeout: float = 2.0,
                    fci: bool = False) -> str | None:
    """Every robot of the serving file at `path` ready (None), or one line naming the first that
    is not. A robot without a control API counts as ready once listed (the file is written when
    every endpoint listens), unless `fci` probes it. `token` (else the file's) for /health."""
    from franka_sim.server import serving_file

    try:
        serving = serving_file.read(path)
    except serving_file.Unreadable as exc:
        return str(exc)
    if not serving_file.running(serving.pid):
        return f"{path}: its server (pid {serving.pid}) is gone"
    for robot in serving.robots:
        host = _reachable(robot.host)
        try:
            if fci:
                reason = fci_problem(host, timeout)
            elif robot.control_port:
                reason = health_problem(host, robot.control_port, token or serving.token,
                                        timeout)
            else:
                reason = None
        except NeverReady as final:
            raise NeverReady(f"{robot.name}: {final}") from None
        if reason is not None:
            return f"{robot.name}: {reason}"
    return None


def _reachable(host: str) -> str:
    """Where a server bound to every address (0.0.0.0, ::) answers this machine."""
    return {"0.0.0.0": "127.0.0.1", "::": "::1"}.get(host, host)


def check_until(host: str, *, wait: float = 0.0, timeout: float = 2.0, fci: bool = False,
                control_port: int = 1340, token: str | None = None,
                serving: Path | None = None, interval: float = 0.2) -> str | None:
    """None once ready; the last attempt's reason when `wait` seconds passed without. With
    `serving` (a serving file), every robot it lists instead of `host`."""
    end = time.monotonic() + wait
    while True:
        try:
            if serving is not None:
                reason = serving_problem(serving, token=token, timeout=timeout, fci=fci)
            else:
                reason = (fci_problem(host, timeout) if fci else
                          health_problem(host, control_port, token, timeout))
        except NeverReady as final:
            return str(final)
        left = end - time.monotonic()
        if reason is None or left <= 0:
            return reason
        time.sleep(min(interval, left))
