"""`franka-sim serve` checks its flags in a forked child while the process the caller started
imports what serving needs, then serves (franka_sim.launch).

An audit hook, inherited by the fork, writes down which process imports what: the pid of each
import of the CLI's libraries and of numpy."""

from __future__ import annotations

import os
import signal
import ssl
import sys
import textwrap
import time
import urllib.error
import urllib.request
from pathlib import Path

import pylibfranka

from franka_sim.testing import ServerProcess, fresh_loopback_address

CLI_LIBRARIES = ("typer", "click", "rich")


def _hooked(log: Path, *, stall_cli: bool = False, lean_guess: bool | None = None) -> list[str]:
    """`franka-sim serve`'s entry point, run under the hook (`stall_cli`: the CLI's child
    sleeps once it imports typer; `lean_guess`: launch's guess, forced)."""
    code = textwrap.dedent(f"""
        import os, sys, time
        LOG, STALL = {str(log)!r}, {stall_cli!r}
        def hook(event, args):
            if event != "import" or not args[0]:
                return
            top = args[0].split(".")[0]
            if top in {CLI_LIBRARIES!r} + ("numpy",):
                with open(LOG, "a") as f:
                    f.write(f"{{os.getpid()}} {{args[0]}}\\n")
                if STALL and top == "typer":
                    time.sleep(600)
        sys.addaudithook(hook)
        import franka_sim.launch as launch
        if {lean_guess!r} is not None:
            launch._lean = lambda argv: {lean_guess!r}
        sys.argv = ["franka-sim"] + sys.argv[1:]
        launch.main()
    """)
    return [sys.executable, "-c", code, "serve"]


def _imports(log: Path) -> list[tuple[int, str]]:
    if not log.exists():
        return []
    return [(int(pid), name) for pid, name in (line.split() for line in log.read_text().split("\n")
                                               if line)]


def test_the_server_is_the_process_started_and_never_imports_the_cli(tmp_path):
    log = tmp_path / "imports"
    host = fresh_loopback_address()
    server = ServerProcess(host, command=_hooked(log) + ["--host", host, "--clock", "lockstep"])
    try:
        server.wait_ready()
        imports = _imports(log)
        cli = {pid for pid, name in imports if name.split(".")[0] in CLI_LIBRARIES}
        assert cli and server.pid not in cli  # the flags were parsed, elsewhere
        assert (server.pid, "numpy") in imports
        assert Path(f"/proc/{server.pid}/task/{server.pid}/children").read_text().split() == []
        robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot
    finally:
        server.stop()


def test_sigterm_while_the_flags_are_checked_stops_both_processes(tmp_path):
    log = tmp_path / "imports"
    host = fresh_loopback_address()
    server = ServerProcess(host, command=_hooked(log, stall_cli=True) + ["--host", host])
    deadline = time.monotonic() + 60
    # the CLI stalled in typer, and the server importing (its SIGTERM handler installed before)
    while not (any(name == "typer" for _, name in _imports(log))
               and (server.pid, "numpy") in _imports(log)):
        assert time.monotonic() < deadline, server.lines
        time.sleep(0.01)
    cli = next(pid for pid, name in _imports(log) if name == "typer")
    assert cli != server.pid
    server.proc.send_signal(signal.SIGTERM)
    assert server.proc.wait(timeout=30) == 0
    while Path(f"/proc/{cli}").exists() and time.monotonic() < deadline:
        time.sleep(0.01)  # (reaped by init once its parent is gone)
    assert not Path(f"/proc/{cli}").exists() or \
        Path(f"/proc/{cli}/stat").read_text().split(")")[1].split()[0] == "Z"
    assert any("stopped (SIGTERM) while starting" in line for line in server.sync())


def test_a_cli_killed_while_checking_the_flags_exits_as_a_shell_says_it(tmp_path):
    log = tmp_path / "imports"
    host = fresh_loopback_address()
    server = ServerProcess(host, command=_hooked(log, stall_cli=True) + ["--host", host])
    deadline = time.monotonic() + 60
    while not any(name == "typer" for _, name in _imports(log)):
        assert time.monotonic() < deadline, server.lines
        time.sleep(0.01)
    cli = next(pid for pid, name in _imports(log) if name == "typer")
    os.kill(cli, signal.SIGKILL)
    assert server.proc.wait(timeout=60) == 128 + signal.SIGKILL
    assert not any("serving on" in line for line in server.sync())


def test_a_guess_the_flags_contradict_starts_afresh_with_what_it_left_out(tmp_path):
    """The imports left OpenSSL out, but the Desk needs TLS: the process execs itself (same
    pid) into a server that has it."""
    host = fresh_loopback_address()
    server = ServerProcess(host, command=_hooked(tmp_path / "imports", lean_guess=True) + [
        "--host", host, "--desk-port", "443"])
    try:
        server.wait_ready()
        cmdline = Path(f"/proc/{server.pid}/cmdline").read_bytes()
        assert b"franka_sim.serving" in cmdline  # started afresh
        assert _https_status(f"https://{host}:443/admin/api/system-status") in (200, 401, 403)
    finally:
        server.stop()


def _https_status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=30,
                                    context=ssl._create_unverified_context()) as reply:
            return reply.status
    except urllib.error.HTTPError as exc:  # (an answer, over TLS)
        return exc.code


def test_help_and_a_refused_flag_exit_as_the_cli_says(tmp_path):
    import subprocess

    host = fresh_loopback_address()
    helped = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--help"],
                            capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0 and "--clock" in helped.stdout
    refused = subprocess.run([sys.executable, "-m", "franka_sim", "serve", "--host", host,
                              "--clock", "sometimes"], capture_output=True, text=True,
                             timeout=60, env={**os.environ, "COLUMNS": "200"})
    assert refused.returncode == 2 and "sometimes" in refused.stderr


def test_modules_in_the_working_directory_do_not_shadow_the_servers_own(tmp_path):
    """A user's `json.py` beside them: a server that starts afresh (a secret on its command
    line) imports the standard library's, not theirs."""
    for name in ("json", "queue", "concurrent"):
        (tmp_path / f"{name}.py").write_text(f"raise SystemExit('shadowed by ./{name}.py')\n")
    host = fresh_loopback_address()
    script = Path(sys.executable).parent / "franka-sim"  # the installed command, as users run it
    server = ServerProcess(host, command=[str(script), "serve", "--host", host,
                                          "--control-token", "t0ken"], cwd=tmp_path)
    try:
        server.wait_ready()
        robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        assert not server.log_matching("shadowed")
    finally:
        server.stop()
