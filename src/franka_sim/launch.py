"""`franka-sim`'s entry point. `serve` runs its two halves at once, on two cores.

Checking the flags needs typer (click, rich: ~50 ms here); serving needs numpy, MuJoCo, uvloop
and franka-sim's own modules (~120 ms). Neither needs the other until the end, so `serve`
forks before either: the child is the CLI (it parses and checks the flags, prints help or the
error, and hands the parsed flags back through a pipe), while this process, the one the caller
started (its pid, its signals, its exit code), imports what serving needs meanwhile and then
serves them (franka_sim.serving). A server never holds typer's modules (serving.py says why).

What the imports leave out (MuJoCo's renderer always, OpenSSL where no flag needs it:
franka_sim.footprint) depends on the flags, so it is guessed from the command line; a guess
the flags contradict costs one exec, not a wrong server. A command line holding a secret (the control API's token, the
Desk's passwords) is not kept either: the server execs itself (same pid) with them in its
environment, where `ps` does not show them.
"""

from __future__ import annotations

import json
import os
import sys

# The flags that need what the imports would leave out, as options or their variables.
_NEEDS_TLS = ("--desk-port", "--web")
_NEEDS_TLS_ENV = ("FRANKA_SIM_DESK_PORT", "FRANKA_SIM_WEB_PORT")


def main() -> None:
    argv = sys.argv[1:]
    if argv[:1] == ["serve"] and hasattr(os, "fork") and not {"--help", "-h"} & set(argv):
        _serve_overlapped(argv)
    from franka_sim.cli import main as cli_main

    cli_main()


def _serve_overlapped(argv: list[str]) -> None:
    read_end, write_end = os.pipe()
    child = os.fork()
    if child == 0:  # the CLI: its result goes back through the pipe (serving.exec_serving)
        os.close(read_end)
        from franka_sim import serving

        serving.hand_back_to(write_end)
        return  # main() runs the CLI
    os.close(write_end)
    from franka_sim import serving

    serving.stop_on_sigterm(also=child)
    hide = _named(argv, serving.SECRET_OPTIONS)
    lean = _lean(argv) and not hide
    if lean:
        serving.import_for_serving(tls=False)
    handed = _read_all(read_end)
    _, status = os.waitpid(child, 0)
    if not handed:  # help, or a flag refused: the CLI said so and how it exited
        code = os.waitstatus_to_exitcode(status)
        sys.exit(128 - code if code < 0 else code)  # (killed by a signal: as a shell says it)
    message = json.loads(handed)
    blob, args = message["blob"], json.loads(message["blob"])
    serving.set_environment(message["env"])
    if hide or (lean and serving.needs_tls(args)):
        serving.become_serving(blob)  # a fresh process, with what the guess left out
    sys.exit(serving.main(blob))


def _lean(argv: list[str]) -> bool:
    """True when the command line names nothing that needs TLS."""
    return not _named(argv, _NEEDS_TLS) and \
        not any(os.environ.get(name, "0") not in ("", "0") for name in _NEEDS_TLS_ENV)


def _named(argv: list[str], options: tuple[str, ...]) -> bool:
    return any(arg.split("=", 1)[0] in options for arg in argv)


def _read_all(fd: int) -> bytes:
    chunks = []
    while chunk := os.read(fd, 65536):
        chunks.append(chunk)
    os.close(fd)
    return b"".join(chunks)


if __name__ == "__main__":
    main()
