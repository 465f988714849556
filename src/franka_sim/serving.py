"""The serving process: what `franka-sim serve` becomes once its flags are parsed.

The CLI (typer, which brings click and rich) parses and checks the flags in a child process
forked at start (franka_sim.launch) and hands them back; the process the caller started serves
them, having imported meanwhile what serving needs. The ~10 MiB the parsing machinery occupies
stay out of a server that runs for hours, possibly dozens of them side by side. The parsed flags
travel as one JSON argument (through the pipe, or `python -m franka_sim.serving ARGUMENT` where
a process starts afresh); this module takes no flags of its own.
"""

from __future__ import annotations

import ctypes
import gc
import json
import logging
import os
import signal
import sys
from dataclasses import asdict
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from franka_sim.footprint import (defer_unused_modules, import_mujoco_without_plugins,
                                  leave_out_renderer, leave_out_tls)
from franka_sim.log_format import FORMAT, OneLine
from franka_sim.log_names import RobotName

if TYPE_CHECKING:
    from franka_sim.config import Config

log = logging.getLogger("franka_sim")


# The control API's token travels in the environment, not on the command line (which `ps`
# shows to every user of the machine).
_TOKEN = "FRANKA_SIM_CONTROL_TOKEN"
_DESK_USERS = "FRANKA_SIM_DESK_USERS"  # (their passwords too)
SECRET_OPTIONS = ("--control-token", "--desk-user")  # whose values `ps` must not show
_SERVING_FILE = "FRANKA_SIM_SERVING_FILE"  # server/serving_file.py's variable


_hand_back: int | None = None  # the pipe to the serving process, in the CLI's child (launch)


def hand_back_to(fd: int) -> None:
    """This process is the CLI forked by franka_sim.launch: exec_serving writes to `fd`."""
    global _hand_back
    _hand_back = fd


def exec_serving(config: Config, *, rt_priority: int, log_level: str,
                 viewer: bool = False) -> None:
    """Become the serving process (does not return), or, in the CLI's child, hand the parsed
    flags back to it (returns)."""
    env = {_TOKEN: config.control_token,
           _DESK_USERS: "\n".join(config.desk_users) if config.desk_users else None}
    blob = serving_argument(config, rt_priority=rt_priority, log_level=log_level, viewer=viewer)
    if _hand_back is not None:
        with os.fdopen(_hand_back, "wb") as pipe:
            pipe.write(json.dumps({"blob": blob, "env": env}).encode())
        return
    set_environment(env)
    become_serving(blob)


def set_environment(env: dict[str, str | None]) -> None:
    """The secrets' variables as `env` has them (None: unset), for the serving process."""
    for name, value in env.items():
        os.environ.pop(name, None)
        if value is not None:
            os.environ[name] = value


def needs_tls(args: dict) -> bool:
    """Whether serving the parsed flags `args` needs OpenSSL, which footprint.py leaves out
    (the Desk; the web view: viser imports `ssl` for a tunnel it never opens). MuJoCo's
    renderer is always left out: the viewer draws in a process of its own (server/viewer.py)."""
    config = args["config"]
    return bool(config.get("desk_port") or config.get("web_port"))


def serving_argument(config: Config, *, rt_priority: int = 0, log_level: str = "info",
                     viewer: bool = False) -> str:
    """The one argument of `python -m franka_sim.serving`: the parsed flags as JSON (the
    control API's token travels in the environment instead)."""
    settings = {name: value.value if isinstance(value, Enum) else
                str(value) if isinstance(value, Path) else value
                for name, value in asdict(config).items()}
    settings.pop("control_token")
    settings.pop("desk_users")
    return json.dumps({"config": settings, "rt_priority": rt_priority, "log_level": log_level,
                       "viewer": viewer})


def become_serving(blob: str) -> None:
    """Replace this process (same pid) with `python -P -m franka_sim.serving blob` (-P: no module
    of the working directory shadows one of the server's)."""
    sys.stdout.flush()
    sys.stderr.flush()
    # A SIGTERM that comes before the new program handles it waits for it, pending (a mask
    # survives exec), rather than being lost: see stop_on_sigterm.
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    os.execv(sys.executable, [sys.executable, "-P", "-m", "franka_sim.serving", blob,
                              *shown_command(sys.argv)])


def shown_command(argv: list[str]) -> list[str]:
    """The words after the serving argument, which `ps` and `pgrep -f "franka-sim serve"` see:
    the command the user gave (`argv`, a serving process's own: kept), its secrets masked.
    The serving process reads only the argument."""
    if argv[2:3] == ["franka-sim"]:  # (a serving process starting again: as it was shown)
        return argv[2:]
    shown, masking = ["franka-sim"], False
    for arg in argv[1:]:
        option, is_pair, _ = arg.partition("=")
        if masking or (is_pair and option in SECRET_OPTIONS):
            arg = f"{option}=***" if is_pair and not masking else "***"
        masking = arg in SECRET_OPTIONS
        shown.append(arg)
    return shown


def _config(settings: dict) -> Config:
    from franka_sim.config import ArmSpec, ClockMode, Config  # (numpy: after SIGTERM's handler)

    settings = dict(settings)
    # (a scene is a packaged name or a path: WorldParts says)
    for name in ("urdf", "record", "desk_cert", "desk_key", "meshes"):
        if settings[name] is not None:
            settings[name] = Path(settings[name])
    settings["clock"] = ClockMode(settings["clock"])
    settings["control_token"] = os.environ.get(_TOKEN)
    users = os.environ.get(_DESK_USERS)
    settings["desk_users"] = tuple(users.split("\n")) if users else ()
    settings["q0"] = tuple(settings["q0"])
    settings["arms"] = tuple(
        ArmSpec(arm["name"], arm["host"], None if arm["base"] is None else tuple(arm["base"]),
                arm.get("robot"), arm.get("tool"))
        for arm in settings.get("arms", ()))
    return Config(**settings)


# Set when a serving process starts again with OpenSSL (see _import_uvloop).
_KEEP_TLS = "_FRANKA_SIM_SERVING_KEEPS_TLS"


def stop_on_sigterm(also: int | None = None) -> None:
    """Until the event loop takes SIGTERM over: as a container's PID 1 this process would
    otherwise never see it (the kernel drops a signal PID 1 has no handler for), and
    `docker stop` during start-up would wait out its timeout. One that came during an exec
    was held pending (become_serving) and stops it now. It exits at once (and stops the CLI's
    child, pid `also`, should it still be checking the flags): an exception raised in the
    middle of an extension module's initialisation would become an ImportError."""
    def stop_now(signum, frame) -> None:
        if also is not None:
            try:
                os.kill(also, signal.SIGTERM)
            except OSError:  # gone already
                pass
        os.write(2, b"franka-sim: stopped (SIGTERM) while starting\n")
        os._exit(0)

    signal.signal(signal.SIGTERM, stop_now)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


def import_for_serving(*, tls: bool) -> None:
    """Import what serving needs, leaving out the renderer, and OpenSSL unless `tls`
    (`needs_tls`). A uvloop that does not import is left for main to handle."""
    _leave_out(tls=tls)
    try:
        import uvloop  # noqa: F401
    except Exception:  # noqa: BLE001 - main says why and starts again with OpenSSL
        return
    import franka_sim.server.sim  # noqa: F401


def _leave_out(*, tls: bool) -> None:
    leave_out_renderer()
    defer_unused_modules()  # before construct and MuJoCo are imported
    if not tls and _KEEP_TLS not in os.environ:
        leave_out_tls()  # before asyncio, uvloop and construct are imported
    import_mujoco_without_plugins()


def main(blob: str) -> int:
    stop_on_sigterm()
    args = json.loads(blob)
    _leave_out(tls=needs_tls(args))
    handler = logging.StreamHandler()
    handler.setFormatter(OneLine(FORMAT, clear_line=sys.stdout.isatty() and sys.stderr.isatty()))
    handler.addFilter(RobotName())  # (a line about one robot of several names it)
    logging.basicConfig(level=args["log_level"].upper(), handlers=[handler])
    if args["rt_priority"]:
        _realtime_scheduling(args["rt_priority"])
    uvloop = _import_uvloop(blob)
    try:
        uvloop.run(_serve(_config(args["config"]), viewer=args.get("viewer", False)))
    except _Failed as exc:
        print(f"franka-sim: {exc}", file=sys.stderr)
        return 1
    return 0


def _import_uvloop(blob: str):
    """uvloop, which reads names off `ssl` as it imports. Should a uvloop this stand-in does not
    satisfy be installed, the process starts again (same pid) with OpenSSL: ~4.5 MiB more."""
    try:
        import uvloop
    except Exception as exc:  # noqa: BLE001 - whatever the stand-in failed to provide
        if _KEEP_TLS in os.environ:
            raise
        log.warning("uvloop does not import without OpenSSL (%s: %s); starting again with it",
                    type(exc).__name__, exc)
        os.environ[_KEEP_TLS] = "1"
        become_serving(blob)
    return uvloop


def _realtime_scheduling(priority: int) -> None:
    """SCHED_FIFO for this thread and every thread it starts later (the cycle thread)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError) as exc:  # no permission, or not Linux
        log.warning("--rt-priority %d not applied (%s): running at normal priority",
                    priority, getattr(exc, "strerror", None) or exc)
    else:
        log.info("running under SCHED_FIFO priority %d", priority)


class _Failed(Exception):
    pass


def _release_unused_heap() -> None:
    """Give the allocator's free pages back (model compilation leaves ~1 MiB behind)."""
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass


async def _serve(config: Config, viewer: bool = False) -> None:
    import asyncio

    from franka_sim.config_rules import ConfigError
    from franka_sim.description.urdf import DescriptionError
    from franka_sim.physics.scene import SceneError
    from franka_sim.server.sim import FrankaSim

    try:
        sim = FrankaSim(config)
    except ConfigError as exc:
        raise _Failed(f"{exc.flag}: {exc}") from None
    except DescriptionError as exc:
        raise _Failed(f"cannot serve {config.urdf}: {exc}") from None
    except SceneError as exc:
        raise _Failed(str(exc)) from None
    except OSError as exc:  # the recording's target, or a file the world is built from
        what = f"cannot record to {config.record}" if config.record is not None else \
            "cannot build the world"
        raise _Failed(f"{what}: {exc.strerror or exc}") from None
    # Everything built so far lives as long as the server: keep it out of the collector's
    # scans, so that no full collection (~13 ms here) ever stalls the 1 kHz stream.
    gc.collect()
    gc.freeze()
    # From here a signal is a clean stop (the recording finished), even one that comes while
    # the endpoints open, right after "serving on".
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        await sim.start()
    except OSError as exc:  # an address in use or that cannot be served: nothing is served
        raise _Failed(exc.strerror or str(exc)) from None
    except SceneError as exc:  # (the world, built in its thread: an arm inside a body)
        raise _Failed(str(exc)) from None
    _release_unused_heap()
    from franka_sim.server.status_line import show_status

    status = asyncio.create_task(show_status(sim))
    stopped, failed = asyncio.create_task(stop.wait()), asyncio.create_task(sim.failed.wait())

    # The robot serves while the viewer's window opens (software GL may take seconds): a stop
    # meanwhile is taken at once, and a window that opens after it is closed.
    viewers: list = []  # the one whose window opens
    opening = asyncio.create_task(_open_viewer(sim, viewers)) if viewer else None
    live = announced = cannot_view = None
    try:
        if opening is not None:
            await asyncio.wait((opening, stopped, failed), return_when=asyncio.FIRST_COMPLETED)
            if opening.done():
                live = opening.result()  # (RuntimeError: it cannot open)
        if not (stopped.done() or failed.done()):
            if os.environ.get(_SERVING_FILE):  # (its module, tempfile's: only then)
                from franka_sim.server.serving_file import announce

                announced = announce(sim)  # what `franka-sim check` asks
            await asyncio.wait((stopped, failed), return_when=asyncio.FIRST_COMPLETED)
    except RuntimeError as exc:
        cannot_view = str(exc)
    finally:
        if announced is not None:
            announced.withdraw()
        stopped.cancel()
        failed.cancel()
        status.cancel()
        if opening is not None and not opening.done():
            await _abandon(opening, viewers)
        if live is not None:
            live.stop()
        if cannot_view is not None:
            await sim.stop()
            raise _Failed(cannot_view)
        if sim.failure is not None:
            # A simulator that stopped simulating must not look alive to a supervisor (Docker's
            # restart policy, Kubernetes): exit non-zero now, however the rest shuts down.
            log.error("exiting: the simulator stopped simulating (%s)", sim.failure)
            await _stop_within(sim, FAILED_EXIT_WITHIN)
            raise _Failed(f"the simulator stopped simulating: {sim.failure}")
        log.info("stopping")
        await sim.stop()


FAILED_EXIT_WITHIN = 0.5  # s the endpoints get to close before a failed server exits anyway


async def _stop_within(sim, seconds: float) -> None:
    import asyncio

    try:
        await asyncio.wait_for(sim.stop(), seconds)
    except (asyncio.TimeoutError, Exception):  # noqa: BLE001 - exiting anyway
        pass


async def _open_viewer(sim, viewers: list):
    import asyncio

    from franka_sim.server.viewer import LiveViewer

    world = await sim.worker.call(lambda physics: physics.world)
    viewer = LiveViewer(world.model, world.data)
    viewers.append(viewer)
    await asyncio.to_thread(viewer.start)  # RuntimeError: it cannot open (the caller says so)
    return viewer


async def _abandon(opening, viewers: list) -> None:
    """The server stops while the viewer's window opens: its process is ended, and waited
    for, before the server exits (none outlives it)."""
    import asyncio

    if not viewers:  # (still asking for the world)
        opening.cancel()
    for viewer in viewers:
        viewer.abandon()
    await asyncio.wait({opening})  # (its start returns at once, refused)
    if not opening.cancelled() and opening.exception() is None:
        opening.result().stop()  # (it had opened just before)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
