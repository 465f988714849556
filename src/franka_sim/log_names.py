"""Which robot a log line is about, in a world of several robots (each arm and the mobile base
is a whole robot, with a client of its own): the cycle thread and the loop do each robot's
work under its name (`about`), and the server's log handler puts that name before the message
(`RobotName`, its format's `%(robot)s`). A world of one robot names none: its lines stay as
they are."""

from __future__ import annotations

import logging
from contextlib import contextmanager
from contextvars import ContextVar

_ROBOT: ContextVar[str | None] = ContextVar("franka_sim_robot", default=None)


@contextmanager
def about(name: str | None):
    """Log what runs inside as about robot `name` (None: no robot)."""
    token = _ROBOT.set(name)
    try:
        yield
    finally:
        _ROBOT.reset(token)


def current() -> str | None:
    """The robot the running work is about (None: the world's own, or a world of one)."""
    return _ROBOT.get()


def name_work(part, name: str, methods: tuple[str, ...]) -> None:
    """Each of `part`'s `methods` runs under `name` from now on (instance attributes that
    shadow the methods: a world of one robot, which names none, calls them as they are)."""
    for method in methods:
        def under(*args, _run=getattr(part, method), **kwargs):
            token = _ROBOT.set(name)
            try:
                return _run(*args, **kwargs)
            finally:
                _ROBOT.reset(token)
        setattr(part, method, under)


class RobotName(logging.Filter):
    """Gives each record `robot`: "NAME: " for a line about a robot of several, else ""."""

    def filter(self, record: logging.LogRecord) -> bool:
        name = _ROBOT.get()
        record.robot = "" if name is None else f"{name}: "
        return True
