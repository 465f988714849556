"""The simulators one pytest worker runs for its tests (the `franka_sim` fixture's backing).

One `franka-sim serve` subprocess per configuration, started when a test first needs it and
reused by every later test of that configuration, each on a loopback address of its own, and
brought back to the same world before every test. A reset is cheap (one HTTP call); a restart
(seconds) happens only when a reset cannot give a clean world: the server died, a motion is
still running, or a client from an earlier test still holds the robot's only FCI connection.
"""

from __future__ import annotations

import gc
import os
import time
from dataclasses import dataclass

from franka_sim.testing.server_process import ServerProcess

CONTROL_PORT = 1340
# The Desk of a simulator that boots locked (the robot's is 443, which needs privileges): a
# test's bring-up code reaches it at `franka_sim.desk` (HOST:PORT).
DESK_PORT = 8443
_START_TIMEOUT = 60.0  # MuJoCo's import and the model's compilation, on a busy CI machine
_CLIENT_GONE_TIMEOUT = 0.25  # a finished test's client: its TCP close is in flight
_ADDRESS_ATTEMPTS = 4


@dataclass(frozen=True)
class SimSettings:
    """What tests can ask of a simulator (`--franka-sim-*` options, the `franka_sim` marker)."""

    clock: str = "lockstep"
    scene: str | None = None  # an absolute path; None: the packaged table and cube
    enforce_motion_limits: bool = False
    enforce_comm_constraints: bool = False
    gripper: bool = True
    desk_boot: str = "ready"  # "locked": as after power-on, its Desk served on DESK_PORT
    robot: str = "fr3"  # the arm: "fr3", or "fer" (the Panda)

    def flags(self) -> list[str]:
        """`franka-sim serve` flags, each setting explicit (and the server started without the
        exported FRANKA_SIM_* settings: `unset_settings`)."""
        flags = ["--clock", self.clock, "--robot", self.robot,
                 "--control-port", str(CONTROL_PORT),
                 "--enforce-motion-limits" if self.enforce_motion_limits
                 else "--no-enforce-motion-limits",
                 "--enforce-comm-constraints" if self.enforce_comm_constraints
                 else "--no-enforce-comm-constraints"]
        if self.scene is not None:
            flags += ["--scene", self.scene]
        if not self.gripper:
            flags.append("--no-gripper")
        flags += ["--desk-boot", self.desk_boot,
                  "--desk-port", str(DESK_PORT if self.desk_boot != "ready" else 0)]
        return flags


# What an exported FRANKA_SIM_* may still say to a test's simulator: the token its control API
# asks for, how much it logs, the look of the meshes, how its kernels and model libraries are
# built. Every other one (a scene, faults, a tool, arms, an address) would change the world the
# tests asked for, so it is taken out of the server's environment.
KEPT_VARIABLES = ("FRANKA_SIM_CONTROL_TOKEN", "FRANKA_SIM_LOG_LEVEL", "FRANKA_SIM_MESHES",
                  "FRANKA_SIM_KERNELS", "FRANKA_SIM_MODEL_LIBRARIES")


def unset_settings(environment) -> dict:
    """The environment's FRANKA_SIM_* settings a test's server must not read, as None (unset),
    and a log level above info lowered to it (see shown_level)."""
    unset = {name: None for name in environment
             if name.startswith("FRANKA_SIM_") and name not in KEPT_VARIABLES}
    if shown_level(environment) is not None:
        unset["FRANKA_SIM_LOG_LEVEL"] = "info"
    return unset


LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


def shown_level(environment) -> str | None:
    """An exported FRANKA_SIM_LOG_LEVEL above info. A test's server still logs its info lines,
    since the pool waits for its start line ("serving on"); the tests' `log` and their reports
    keep the lines at this level and above."""
    level = (environment.get("FRANKA_SIM_LOG_LEVEL") or "").upper()
    return level if level in LEVELS[2:] else None


def at_level(lines: list[str], level: str | None) -> list[str]:
    """The log lines at `level` and above (None: all); a line that is no record (a traceback's)
    is kept."""
    if level is None:
        return lines
    below = set(LEVELS[:LEVELS.index(level)])
    return [line for line in lines if _level_of(line) not in below]


def _level_of(line: str) -> str | None:
    """"2026-12-07 05:12:57,972 INFO franka_sim.server.sim: …": INFO."""
    words = line.split(None, 3)
    return words[2] if len(words) > 2 else None


def worker_address(worker: str | None, pid: int, n: int) -> str:
    """The n-th server address of a pytest worker: 127.<220 + worker>.<pid>.<2 + n>.

    The second octet is the xdist worker's number (gw3 -> 223; 220 without xdist), the third
    the worker process's pid (mod 256) so that concurrent pytest runs on one machine stay
    apart, the fourth counts this worker's servers. 220 and above is outside the suite's own
    `fresh_loopback_address` range and never 127.0.0.1, where a user's `franka-sim serve` runs;
    a clash anyway (same worker number, pids 256 apart) is met by moving on to the next n.
    """
    number = int(worker[2:]) if worker and worker.startswith("gw") and worker[2:].isdigit() else 0
    return f"127.{220 + number % 35}.{pid % 256}.{2 + n % 250}"


class ServerPool:
    """This worker's servers, by settings."""

    def __init__(self, worker: str | None, pid: int) -> None:
        self.worker, self.pid = worker, pid
        self._servers: dict[SimSettings, tuple[ServerProcess, object]] = {}
        self._failed: dict[SimSettings, str] = {}
        self._started = 0

    def prepared(self, settings: SimSettings,
                 recording: str | None = None) -> tuple[ServerProcess, object]:
        """(server, its `Control`) of these settings, in the start world and with no client;
        recording from there into `recording` (a path) if given."""
        if settings in self._failed:
            raise RuntimeError(self._failed[settings])
        entry = self._servers.get(settings)
        if entry is not None and not _reset(*entry):
            entry[0].stop()
            entry = None
        if entry is None:
            try:
                entry = self._start(settings)
            except RuntimeError as exc:
                self._failed[settings] = str(exc)  # one failed start per settings, not per test
                raise
            self._servers[settings] = entry
        if recording is not None and not _start_recording(entry[1], recording):
            # A client of an earlier test still holds the Hand (or the recording could not
            # start for another reason): a server of its own, where none can be connected.
            entry[0].stop()
            entry = self._servers[settings] = self._start(settings)
            try:
                entry[1].start_recording(recording)
            except Exception as exc:  # noqa: BLE001 - said as the test's setup failure
                raise RuntimeError(f"franka-sim: cannot record to {recording}: {exc}") from None
        return entry

    def _start(self, settings: SimSettings) -> tuple[ServerProcess, object]:
        from franka_sim.control import Control

        for _ in range(_ADDRESS_ATTEMPTS):
            host = worker_address(self.worker, self.pid, self._started)
            self._started += 1
            # (spawned from pytest's main thread, whose end the death signal follows)
            server = ServerProcess(host, *settings.flags(), env=unset_settings(os.environ),
                                   die_with_parent=True)
            try:
                server.wait_ready(_START_TIMEOUT)
            except RuntimeError:
                if server.log_matching("already in use"):
                    continue  # another run's server on this address: the next one
                raise
            # The server reads an exported FRANKA_SIM_CONTROL_TOKEN as its token.
            control = Control(host, port=CONTROL_PORT,
                              token=os.environ.get("FRANKA_SIM_CONTROL_TOKEN") or None)
            _wait_healthy(server, control)
            return server, control
        raise RuntimeError(f"franka-sim: {_ADDRESS_ATTEMPTS} addresses in a row were taken")

    def stop_all(self) -> None:
        for server, _ in self._servers.values():
            server.stop()
        self._servers.clear()


def _wait_healthy(server: ServerProcess, control, timeout: float = 10.0) -> None:
    """"serving on" is the FCI; wait until the control API answers ready as well."""
    from franka_sim.control import ControlError

    end = time.monotonic() + timeout
    while True:
        try:
            if control.health().get("ready"):
                return
        except ControlError:
            pass
        if time.monotonic() > end or server.proc.poll() is not None:
            server.stop()
            raise RuntimeError("franka-sim's control API did not become ready:\n"
                               + "\n".join(server.lines))
        time.sleep(0.02)


def _reset(server: ServerProcess, control) -> bool:
    """Bring a running server back to the start world, without faults; False when only a
    restart can."""
    from franka_sim.control import ControlError

    if server.proc.poll() is not None:
        return False
    def connected() -> bool:  # (an FCI client, or a Hand's: the next test's would be refused)
        health = control.health()
        return health["client_connected"] or health.get("tool_client_connected", False)

    try:
        if connected():
            # A finished test's client held only by a reference cycle closes on a collection
            # (~12 ms inside pytest, so only when a client is still there).
            gc.collect()
        end = time.monotonic() + _CLIENT_GONE_TIMEOUT
        while connected():
            if time.monotonic() > end:
                return False  # still connected (e.g. kept alive by a failed test's traceback)
            time.sleep(0.01)
        control.reset()
        # Faults a test set through the control API outlive a reset (docs/control_api.md);
        # the pool's servers start without any.
        if control.faults()["spec"] is not None:
            control.clear_faults()
    except ControlError:  # Conflict: a motion still runs; or the server no longer answers
        return False
    return True



def _start_recording(control, path: str) -> bool:
    """Start recording into `path` (the server resets first); False when it would not: a
    client still connected after a collection and a moment's wait, or no answer."""
    from franka_sim.control import Conflict, ControlError

    end = time.monotonic() + _CLIENT_GONE_TIMEOUT
    collected = False
    while True:
        try:
            control.start_recording(path)
            return True
        except Conflict:
            if time.monotonic() > end:
                return False
            if not collected:
                gc.collect()  # a finished test's Hand client held only by a reference cycle
                collected = True
            time.sleep(0.01)
        except ControlError:
            return False
