"""Run a libfranka program as if the kernel were PREEMPT_RT.

libfranka's Robot refuses to start a control loop unless /sys/kernel/realtime reads 1, and its
C++ examples do not ask for RealtimeConfig::kIgnore. `as_realtime(command)` runs the command in
a mount namespace of its own where a tmpfs over /sys/kernel holds that file: the program is
unmodified, nothing outside its namespace changes. It takes root (CAP_SYS_ADMIN, and
CAP_SYS_NICE for the SCHED_FIFO priority libfranka then sets) and unshare(1).
"""

from __future__ import annotations

import os
import shutil
import sys

_WRAPPER = ("unshare", "--mount", "sh", "-c",
            'mount -t tmpfs none /sys/kernel && echo 1 > /sys/kernel/realtime && exec "$0" "$@"')


def cannot_fake() -> str | None:
    """Why this machine cannot run a program as_realtime (None: it can)."""
    if sys.platform != "linux" or os.geteuid() != 0 or shutil.which("unshare") is None:
        return "faking /sys/kernel/realtime takes root and unshare(1) on Linux"
    return None


def as_realtime(command: list[str]) -> list[str]:
    """`command`, run with /sys/kernel/realtime reading 1."""
    return [*_WRAPPER, *command]
