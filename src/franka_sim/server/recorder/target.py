"""Where a recording goes: a file written as a temporary beside it and put in its place when
the recording starts, or a device written as it is.

A recording is opened before it starts (`serve --record` when the simulator is made, the
control API's before its reset), and a start may still fail (an address in use) or never come
(an embedded simulator made and dropped). Until the start the file that was there stays as it
was: a failed start no longer costs the last run's recording. The target is claimed at once: a
file another process records to now (it holds an flock on it for as long as it records) is
refused before a byte of it changes, and so is one this process may not write. A device
(/dev/null) is written as it is; a FIFO cannot take one (MCAP's writer seeks: refused before
it is opened, which would wait for a reader); a file system without locks records unlocked.
"""

from __future__ import annotations

import errno
import fcntl
import logging
import os
import stat
import weakref
from pathlib import Path

log = logging.getLogger(__name__)


class Target:
    """The open stream a recording to `path` writes (`stream`), and its place: `commit()`
    puts it there, `abandon()` removes it unless it was."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.temporary: Path | None = None
        try:
            mode = os.stat(path).st_mode
        except FileNotFoundError:
            mode = None
        if mode is not None and stat.S_ISFIFO(mode):
            raise OSError(errno.ESPIPE, "a FIFO cannot take a recording (it is written with "
                          "seeks)", str(path))
        if mode is not None and not stat.S_ISREG(mode):
            self.stream = os.fdopen(os.open(path, os.O_WRONLY), "wb")
            return
        self.place = Path(os.path.realpath(path))  # (a link: the file it names is replaced)
        if mode is not None:
            _check_unclaimed(self.place)
            if not os.access(self.place, os.W_OK):
                raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        self.temporary = self.place.with_name(f".{self.place.name}.{os.getpid()}.part")
        fd = os.open(self.temporary, os.O_WRONLY | os.O_CREAT, 0o666)
        try:
            _lock(fd, path)  # (this process's other recording to the same target: refused,
            os.ftruncate(fd, 0)  # its temporary left as it is)
        except BaseException:
            os.close(fd)
            raise
        self.stream = os.fdopen(fd, "wb")
        # Made and never started (an embedder's simulator dropped): the temporary goes.
        self._finalizer = weakref.finalize(self, _remove, self.temporary)

    def commit(self) -> None:
        """The recording starts: its file takes the target's place (OSError: another
        process records to the target since it was claimed)."""
        temporary = self.temporary
        if temporary is None:
            return
        try:
            replaced = os.stat(self.place).st_size
        except FileNotFoundError:
            replaced = 0
        if replaced:
            _check_unclaimed(self.place)
        os.replace(temporary, self.place)
        self.temporary = None
        self._finalizer.detach()
        if replaced:  # (a container restarted with the same --record: the last run's file)
            log.warning("recording to %s replaces the %d-byte file that was there",
                        self.path, replaced)

    def abandon(self) -> None:
        """The recording never started: its temporary goes, the target stays as it was."""
        self.stream.close()
        if self.temporary is not None:
            _remove(self.temporary)
            self.temporary = None
            self._finalizer.detach()


def _remove(path: Path) -> None:
    path.unlink(missing_ok=True)


def _check_unclaimed(path: Path) -> None:
    """OSError (EBUSY) if another process records to the file at `path` now."""
    fd = os.open(path, os.O_RDONLY)
    try:
        _lock(fd, path)
    finally:
        os.close(fd)  # (the probe's lock goes with it)


def _lock(fd: int, path: Path) -> None:
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise OSError(errno.EBUSY, "another process is recording to it", str(path)) from None
    except OSError as exc:
        if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
            raise
        log.warning("recording to %s unlocked (its file system has no locks: %s): another "
                    "process given the same path would write over it", path, exc.strerror)
