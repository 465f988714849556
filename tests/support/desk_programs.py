"""Desk client programs, each run in a child Python (franky's and pylibfranka's bindings cannot
share a process; franka-desk keeps its token under the child's own HOME):

    python desk_programs.py PROGRAM ADDRESS USER PASSWORD [ARG]

A program prints `UP`, `DOWN`, `TOOK`, `REFUSED <reason>` or `EVENTS <json>` lines as it goes;
where it prints `WAIT` it reads one line of stdin before going on (the test's cue).
"""

from __future__ import annotations

import json
import sys


def say(*words) -> None:
    print(*words, flush=True)


def wait() -> None:
    say("WAIT")
    sys.stdin.readline()


def franky_desk(address, user, password, _=None) -> None:
    import franky

    with franky.Desk(address, user, password) as desk:
        desk.take_control(wait_timeout=5)
        desk.execute_self_test()  # (with the brakes locked, as the robot tests them)
        desk.recover()  # nothing to recover: a no-op
        say("CHECKED", desk.get_recovery_status())
        desk.unlock_brakes()
        desk.set_mode_execution()
        desk.enable_fci()
        say("UP", desk.brake_state.value, desk.operating_mode.value, desk.get_fci_status())
        wait()
        desk.disable_fci()
        desk.lock_brakes()
        desk.release_control()
        say("DOWN", desk.brake_state.value, desk.get_fci_status())


def franky_web_session(address, user, password, _=None) -> None:
    import franky

    with franky.DeskWebSession(address, user, password) as desk:
        desk.take_control(wait_timeout=5)
        desk.unlock_brakes()
        desk.set_mode_execution()
        desk.enable_fci()
        say("UP", desk.brake_state.value, desk.operating_mode.value)
        wait()
        desk.lock_brakes()
        desk.release_control()
        say("DOWN", desk.brake_state.value)


def franka_desk(address, user, password, _=None) -> None:
    from franka_desk import FrankaDeskClient

    client = FrankaDeskClient(f"https://{address}", user, password, retry_delay=0.1)
    client.bring_up(wait_timeout=10)
    say("UP", client.get_fci_state(), client.get_operating_mode())
    wait()
    client.tear_down()
    say("DOWN", client.get_fci_state(), client.get_joints()[0]["brakeStatus"])


def deskapi(address, user, password, _=None) -> None:
    from deskapi import FrankDeskApi

    api = FrankDeskApi(address, user, password).open()
    api.take_control(wait_timeout=5)
    api.unlock_brakes()
    api.change_mode_execution()
    api.activate_fci()
    say("UP", api.get_fci_status()["status"], api.get_operating_mode()["status"])
    wait()
    api.deactivate_fci()
    api.lock_brakes()
    api.close()
    say("DOWN")


def franky_take(address, user, password, how="wait:1") -> None:
    """Take control (`wait:S`: the system 5+ API, S s; `force:S`: the older Desk, forced),
    hold it until told, then release it."""
    import franky

    kind, seconds = how.split(":")
    session = (franky.Desk if kind == "wait" else franky.DeskWebSession)(address, user, password)
    with session:
        try:
            session.take_control(wait_timeout=float(seconds), force=kind == "force")
        except franky.desk.TakeControlTimeoutError as exc:
            say("REFUSED", type(exc).__name__)
            return
        say("TOOK", session.has_control)
        wait()
        say("STILL", session.has_control)


def franky_pilot(address, user, password, _=None) -> None:
    import franky

    from websockets.exceptions import InvalidMessage

    with franky.Desk(address, user, password) as desk:
        for attempt in range(3):  # franky gives the event socket's TLS and WebSocket handshake
            try:  # 2 s, which a machine loaded by other tests can take (then it sees EOF)
                desk.poll_buttons(0.0)  # the event socket is open from here on
                break
            except (TimeoutError, InvalidMessage):
                if attempt == 2:
                    raise
        say("LISTENING")
        events = desk.poll_buttons(timeout=60)
        while len(events) < 2:
            events += desk.poll_buttons(timeout=60)
        say("EVENTS", json.dumps([[e.button.value, e.pressed] for e in events]))


if __name__ == "__main__":
    program, *args = sys.argv[1:]
    globals()[program](*args)
