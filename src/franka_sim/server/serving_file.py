"""What a serving process serves, written down for `franka-sim check` (FRANKA_SIM_SERVING_FILE).

A container's health check is a process of its own: it sees the container's environment but not
the flags given to `serve`, so it cannot tell which addresses (`--arm`, `--mobile-base`), which
control port and which token to ask. When the variable names a path, the serving process writes
there, once every robot listens, each robot's name, address and control API port (and the
token, hence the file is its user's alone), and removes it when it stops. The file is replaced
whole (written beside, then renamed): a reader never sees half of it.
"""

from __future__ import annotations

import json
import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

VARIABLE = "FRANKA_SIM_SERVING_FILE"
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Served:
    """One robot as its control API is reached: `control_port` 0 when it has none."""
    name: str
    host: str
    control_port: int


@dataclass(frozen=True)
class Serving:
    """A serving file's contents: the robots, the control API's token, the writer's pid."""
    robots: tuple[Served, ...]
    token: str | None
    pid: int


class Unreadable(Exception):
    """No serving file there (nothing serves yet, or any more), or not one this module wrote."""


class Announcement:
    """The file one serving process wrote (`announce`); `withdraw` removes it. Without a path:
    nothing written, nothing removed."""

    def __init__(self, path: Path | None) -> None:
        self.path = path

    def withdraw(self) -> None:
        """Remove the file, if it is still this process's (another server given the same
        path since wrote its own: that one stays)."""
        if self.path is None:
            return
        try:
            if read(self.path).pid != os.getpid():
                self.path = None
                return
        except Unreadable:
            self.path = None
            return
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            log.warning("cannot remove %s (%s): `franka-sim check` will still read it",
                        self.path, exc.strerror or exc)
        self.path = None


def announce(sim, environ=os.environ) -> Announcement:
    """Write what `sim` (a started FrankaSim) serves where FRANKA_SIM_SERVING_FILE says, if it
    says. A file that cannot be written is a warning: the robots serve regardless."""
    where = environ.get(VARIABLE)
    if not where:
        return Announcement(None)
    path = Path(where)
    serving = Serving(tuple(Served(robot.name, robot.host, sim.config.control_port)
                            for robot in sim.robots), sim.config.control_token, os.getpid())
    try:
        write(path, serving)
    except OSError as exc:
        log.warning("cannot write %s=%s (%s): `franka-sim check` without HOST will not find "
                    "this server", VARIABLE, path, exc.strerror or exc)
        return Announcement(None)
    return Announcement(path)


def write(path: Path, serving: Serving) -> None:
    text = json.dumps({"pid": serving.pid, "token": serving.token,
                       "robots": [{"name": r.name, "host": r.host, "control_port": r.control_port}
                                  for r in serving.robots]})
    # mkstemp: mode 0600, the token's protection; in the same folder, so the rename is atomic
    fd, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "w") as file:
            file.write(text)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def read(path: Path) -> Serving:
    """The file's contents (Unreadable: absent, or not a serving file)."""
    try:
        data = json.loads(path.read_text())
        robots = tuple(Served(str(r["name"]), str(r["host"]), int(r["control_port"]))
                       for r in data["robots"])
        return Serving(robots, data.get("token"), int(data["pid"]))
    except FileNotFoundError:
        raise Unreadable(f"{path}: absent (the server is not serving yet, or any more, or "
                         "could not write it: its log says so)") from None
    except OSError as exc:
        raise Unreadable(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except (ValueError, KeyError, TypeError):
        raise Unreadable(f"{path}: not a serving file franka-sim wrote") from None


def running(pid: int) -> bool:
    """Whether the process that wrote a file still runs (a server killed outright leaves its
    file behind)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's: it exists
        return True
    return True
