"""An operation's arguments checked before anything changes (BadRequest says what is wrong),
and the few readings every robot's operations give alike."""

from __future__ import annotations

import math
from numbers import Real
from typing import Any

import numpy as np

from franka_sim.control.errors import BadRequest, Failed
from franka_sim.protocol.enums import RobotMode


def mode_name(mode: RobotMode) -> str:
    """libfranka's name of a robot mode ("Idle", "Move", "Reflex", ...)."""
    return mode.name[1:]


def numbers(name: str, value: Any, n: int) -> np.ndarray:
    """`value` as n finite numbers, or BadRequest saying what is wrong with it."""
    if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__len__"):
        raise BadRequest(f"{name} must be a list of {n} numbers, not {value!r}")
    if len(value) != n:
        raise BadRequest(f"{name} must have {n} numbers, not {len(value)}")
    if not all(isinstance(v, (Real, np.floating, np.integer)) and not isinstance(v, bool)
               for v in value):
        raise BadRequest(f"{name} must be {n} numbers, not {list(value)!r}")
    try:
        array = np.array(value, dtype=float)
    except OverflowError:  # an integer past any float (JSON's 1 and 400 zeros)
        raise BadRequest(f"{name} must be finite, not {list(value)!r}"[:300]) from None
    if not np.all(np.isfinite(array)):
        raise BadRequest(f"{name} must be finite, not {array.tolist()}")
    return array


def within(name: str, array: np.ndarray, bound: float, unit: str) -> np.ndarray:
    """`array` if its norm is at most `bound`, else BadRequest: past it the physics no longer
    stays stable (a body flung to where MuJoCo gives up on the world, an arm torn out of its
    joint limits)."""
    if np.linalg.norm(array) > bound:
        raise BadRequest(f"{name} {np.linalg.norm(array):.6g} {unit} is over the "
                         f"{bound:g} {unit} the simulator accepts")
    return array


def number(name: str, value: Any) -> float:
    """`value` as one finite number, or BadRequest."""
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise BadRequest(f"{name} must be a number, not {value!r}")
    try:
        value = float(value)
    except OverflowError:  # an integer past any float
        raise BadRequest(f"{name} must be finite, not {value!r}"[:300]) from None
    if not math.isfinite(value):
        raise BadRequest(f"{name} must be finite, not {value}")
    return value


def body_name(value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise BadRequest(f"body must be a body's name, not {value!r}")
    return value


def refuse_if_failed(worker) -> None:
    """Failed (503, with the reason) once the cycle thread (its `failure`) stopped stepping
    the world: a probe must not keep a dead simulator in service."""
    if worker.failure is not None:
        raise Failed(f"the simulator stopped simulating: {worker.failure}")
