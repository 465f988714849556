"""A vacuum gripper (Cobot Pump) client for the combination matrix: panda-python 1.1.1's
VacuumGripper (libfranka 0.9.2), run in its own virtual environment, on its own beside the arm's
client (it opens no robot connection).

    python tests/support/pump_program.py HOST

Reads the pump's state, vacuums with the cup in the air (nothing to seal: the pump gives up at
the timeout), reads it again, stops the pump and reads it once more. Prints one JSON line: the
server's version, each answer and the states.
"""

from __future__ import annotations

import datetime
import json
import sys

from panda_py import libfranka

TIMEOUT = datetime.timedelta(milliseconds=200)


def _state(pump) -> dict:
    s = pump.read_once()
    return {"part_present": s.part_present, "in_control_range": s.in_control_range,
            "device_status": str(s.device_status).rsplit(".")[-1], "vacuum": s.vacuum,
            "time": s.time.to_msec()}


def main(host: str) -> dict:
    pump = libfranka.VacuumGripper(host)
    out = {"server_version": pump.server_version(), "initial": _state(pump)}
    out["vacuumed"] = pump.vacuum(75, TIMEOUT)
    out["after_vacuum"] = _state(pump)
    out["stopped"] = pump.stop()
    out["final"] = _state(pump)
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1])))
