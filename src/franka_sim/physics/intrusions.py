"""What an arm put at a pose would be inside: its bodies' overlaps with the rest of the world,
and with each other.

A real arm cannot be set down inside the table, nor folded into itself. A reset or a starting
pose that would put it there is refused (the control API's 409, serve's start), rather than
leaving MuJoCo's contact to push the arm out with hundreds of newtons in the first steps.
Contacts are found on a data of their own (the world's state is not touched), from the model's
collision pairs as the engine steps them: an overlap deeper than DEPTH counts; shallower is
touching (a resting contact's own depth is well under a millimetre).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

DEPTH = 2e-3  # m of overlap beyond which a body is inside another, not touching it


@dataclass(frozen=True)
class Intrusion:
    arm_body: str  # the arm's body (a link, the hand, a finger)
    other: str  # what it would be inside (the table, an object, another arm's link)
    depth: float  # m

    def __str__(self) -> str:
        return f"{self.arm_body} into {self.other} ({1e3 * self.depth:.0f} mm deep)"


def subtree(model: mujoco.MjModel, tops) -> frozenset[int]:
    """The bodies named in `tops` and every body below them (an arm's: its fixed first link
    and the chain from its first joint, hand and fingers included)."""
    found = {model.body(name).id for name in tops}
    for body in range(1, model.nbody):  # (MuJoCo numbers a child after its parent)
        if int(model.body_parentid[body]) in found:
            found.add(body)
    return frozenset(found)


def contacts(model: mujoco.MjModel, data: mujoco.MjData) -> list[tuple[int, int, float]]:
    """(body, body, depth) of each contact of two geoms `data` holds (a flexible body's have
    no geom: no scene has one). Read through the contact arrays: the bindings' per-contact
    objects would fault ~0.6 MiB of their code into every server, which checks its arms at
    start."""
    n = data.ncon
    bodies = model.geom_bodyid
    return [(int(bodies[g1]), int(bodies[g2]), -dist)
            for (g1, g2), dist in zip(data.contact.geom[:n].tolist(),
                                      data.contact.dist[:n].tolist())
            if g1 >= 0 and g2 >= 0]


def intrusions(model: mujoco.MjModel, qpos: np.ndarray, arm: frozenset[int],
               mocap: tuple[np.ndarray, np.ndarray] | None = None) -> list[Intrusion]:
    """The overlaps deeper than DEPTH of the `arm`'s bodies with any other body, or with one
    another (the pairs the engine collides: not a joint's two bodies), the world at `qpos` and
    its mocap bodies (the mobile base) at `mocap` (positions, quaternions; None: where the
    model puts them): deepest first, one per pair of bodies."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    if mocap is not None:
        data.mocap_pos[:], data.mocap_quat[:] = mocap
    mujoco.mj_fwdPosition(model, data)
    deepest: dict[tuple[int, int], float] = {}
    for a, b, depth in contacts(model, data):
        if a not in arm:
            if b not in arm:
                continue  # two other bodies
            a, b = b, a
        if depth > DEPTH and depth > deepest.get((a, b), 0.0):
            deepest[(a, b)] = depth
    found = [Intrusion(model.body(a).name, model.body(b).name if b else "the world's geometry",
                       depth)
             for (a, b), depth in deepest.items()]
    return sorted(found, key=lambda i: -i.depth)
