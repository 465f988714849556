"""A simulator booted locked with its Desk on 8443, as the Desk's client tests share it."""

from __future__ import annotations

from contextlib import contextmanager

from franka_sim.testing import running_sim

USER, PASSWORD = "admin", "secret"
PORT = 8443  # unprivileged; the robot's 443 is the same code (docs/desk.md)


@contextmanager
def locked_desk(tmp_path_factory, *flags: str):
    """A lockstep simulator booted locked, its Desk on PORT for USER, its certificate kept in
    a data folder of its own; `flags`: more `serve` flags."""
    data = tmp_path_factory.mktemp("desk-data")
    with running_sim("--clock", "lockstep", "--desk-port", str(PORT), "--desk-boot", "locked",
                     "--desk-user", f"{USER}:{PASSWORD}", *flags,
                     env={"XDG_DATA_HOME": str(data)}) as sim:
        yield sim
