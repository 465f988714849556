"""Which robot a log line is about, in a world of several robots (each arm and the mobile base
is a whole robot, with a client of its own): the cycle thread and the loop do each robot's
work under its name (`about`), and the server's log handler puts that name before the message
(`RobotName`, its format's `%(robot)s`). A world of one robot names none: its lines stay as
they are.

Likewise a process that embeds several simulators at once (several `FrankaSim`s) names each
one's lines by its first robot's address: what a simulator's start and stop begin (its tasks,
its sockets' callbacks, its threads: `ContextThread`) runs under its `SimName`. `serve`'s
process, one simulator, names none."""

from __future__ import annotations

import contextvars
import logging
import threading
from contextlib import contextmanager
from contextvars import ContextVar

_ROBOT: ContextVar[str | None] = ContextVar("franka_sim_robot", default=None)
_SIM: ContextVar["SimName | None"] = ContextVar("franka_sim_sim", default=None)


class SimName:
    """One simulator's name, shown on its lines while other simulators serve in the process."""

    _serving: set["SimName"] = set()

    def __init__(self, name: str) -> None:
        self.name = name

    @contextmanager
    def current(self):
        """What runs inside, and what it starts, is this simulator's work."""
        token = _SIM.set(self)
        try:
            yield
        finally:
            _SIM.reset(token)

    def serving(self, serving: bool) -> None:
        (SimName._serving.add if serving else SimName._serving.discard)(self)

    @property
    def shown(self) -> bool:
        return len(SimName._serving) > 1


class ContextThread(threading.Thread):
    """A thread that runs in the context it was started from (a thread otherwise starts in an
    empty one): its lines name the simulator and robot that started it."""

    def start(self) -> None:
        self._context = contextvars.copy_context()
        super().start()

    def run(self) -> None:
        self._context.run(super().run)


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
    """Gives each record `robot`: "NAME: " for a line about a robot of several, else "";
    "SIMULATOR: " before it while several simulators serve in the process."""

    def filter(self, record: logging.LogRecord) -> bool:
        name, sim = _ROBOT.get(), _SIM.get()
        record.robot = ("" if sim is None or not sim.shown else f"{sim.name}: ") + (
            "" if name is None else f"{name}: ")
        return True
