"""A panda-python 1.1.1 program driving the vacuum gripper (libfranka 0.9.2's VacuumGripper),
run in a virtual environment of its own (tests/clients/test_panda_python_vacuum.py makes it).

    python tests/support/panda_py_vacuum_program.py HOST PLAN_JSON

Moves the cup onto the part (`above`, then slowly `at`), vacuums it, lifts it (`above`,
`speed` as the plan says), carries it over `place_above` and down to `place_at`, drops it off
and rises again; a plan with no `place_at` only lifts (and `swing`s the arm) (`thresholds`: the collision
thresholds, Nm and N, for a part heavy enough to trip the default ones). Prints one JSON line: the pump's answers
and the states it read along the way.
"""

from __future__ import annotations

import datetime
import json
import sys

import numpy as np
import panda_py
from panda_py import libfranka

ONE_SECOND = datetime.timedelta(seconds=1)


def _state(vacuum) -> dict:
    s = vacuum.read_once()
    return {"in_control_range": s.in_control_range, "part_detached": s.part_detached,
            "part_present": s.part_present, "device_status": str(s.device_status).rsplit(".")[-1],
            "actual_power": s.actual_power, "vacuum": s.vacuum, "time": s.time.to_msec()}


def main(host: str, plan: dict) -> dict:
    panda = panda_py.Panda(host)
    if plan.get("thresholds"):  # a heavy part: the robot should not take its weight for a collision
        t = plan["thresholds"]
        panda.get_robot().set_collision_behavior([t] * 7, [t] * 7, [t] * 6, [t] * 6)
    vacuum = libfranka.VacuumGripper(host)
    out = {"server_version": vacuum.server_version(), "initial": _state(vacuum)}
    panda.move_to_joint_position(np.array(plan["above"]))
    panda.move_to_joint_position(np.array(plan["at"]), speed_factor=0.05)
    out["vacuumed"] = vacuum.vacuum(plan.get("setpoint", 75), ONE_SECOND)
    out["after_vacuum"] = _state(vacuum)
    panda.move_to_joint_position(np.array(plan["above"]), speed_factor=plan["speed"])
    out["lifted"] = _state(vacuum)
    if "swing" in plan:  # a turn of the arm at `swing_speed` with the part
        panda.move_to_joint_position(np.array(plan["swing"]), speed_factor=plan["swing_speed"])
        out["swung"] = _state(vacuum)
    if "place_at" in plan:
        panda.move_to_joint_position(np.array(plan["place_above"]), speed_factor=0.1)
        panda.move_to_joint_position(np.array(plan["place_at"]), speed_factor=0.05)
        out["carried"] = _state(vacuum)
        out["dropped"] = vacuum.drop_off(ONE_SECOND)
        out["after_drop"] = _state(vacuum)
        panda.move_to_joint_position(np.array(plan["place_above"]), speed_factor=0.1)
    out["stopped"] = vacuum.stop()
    out["final"] = _state(vacuum)
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], json.loads(sys.argv[2]))))
