"""The world's bodies by name: which are free, where they are, moving one, pushing one.

What a test does to the world from outside (the control API): read a body's pose and velocity,
put a free body (an object of the scene) somewhere at rest, and push a body with a wrench for a
number of steps, as a person would. A push goes through xfrc_applied, which the arm's external
torque already counts as the environment's (physics/external_torque.py), so the robot's estimate,
its contact flags and its collision reflexes see it. It is counted down in steps, not in wall
time, so the same pushes at the same cycles give the same bits.

Names are MuJoCo's: the arm's links ("link1" … "link7", "link0" its base), "hand", the fingers,
and the scene's bodies ("scene/cube"). `find` also takes the names franka_description uses for
the same bodies ("fr3_link7", "fr3_hand"; a Panda's "fer_link7", older ones' "panda_link7"),
after an arm's name too ("left/fr3_link7"), and a scene body without its prefix ("cube").
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from franka_sim.physics.scene import SCENE_PREFIX

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_XBODY = int(mujoco.mjtObj.mjOBJ_XBODY)  # a body's own frame (mjOBJ_BODY: its centre of mass)
# franka_description's link names: fr3_link7, fr3_hand; the Panda's fer_link7 (panda_ before)
ROBOT_PREFIXES = ("fr3_", "fer_", "panda_")


def _without_prefix(name: str) -> str:
    """`name` with franka_description's prefix taken off its last part ("left/fr3_link7":
    "left/link7")."""
    arm, slash, link = name.rpartition("/")
    for prefix in ROBOT_PREFIXES:
        if link.startswith(prefix):
            return arm + slash + link.removeprefix(prefix)
    return name


class UnknownBody(KeyError):
    """No body of the world has this name."""


class NotFree(ValueError):
    """Only a free body can be placed: args (its name, why this one cannot: `Bodies.why_fixed`)."""


class Inside(ValueError):
    """A body placed there would be inside another: args (its name, the deepest overlap:
    physics/intrusions.py Intrusion)."""


class Immovable(ValueError):
    """A push cannot move the body: args (its name, why: `Bodies.anchored`)."""


class TooViolent(ValueError):
    """A push would fling a free body faster than the step integrates it (the message says
    how fast)."""


# What a push may give a free body from rest, were nothing in its way: faster, a 1 ms step
# no longer integrates it (1 Nm about z on the 5 cm cube for 1 s spins it to ~2e4 rad/s and,
# a torque that cannot lift it, lifts it 16 m; dropped at ~8 m/s it passes through the 4 cm
# tabletop before the soft contact stops it, at ~6 m/s it does not).
MAX_PUSHED_SPEED = 10.0  # m/s
MAX_PUSHED_SPIN = 100.0  # rad/s


@dataclass(frozen=True)
class BodyState:
    """A body's frame in the world: position (3,), quaternion (w, x, y, z), and the velocity of
    its frame's origin, linear and angular, in world axes."""

    position: np.ndarray
    quaternion: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    free: bool


class Bodies:
    """The named bodies of one model and data (the world body excluded)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self._model, self._data = model, data
        self.names = tuple(model.body(i).name for i in range(1, model.nbody))
        self._ids = {name: i for i, name in enumerate(self.names, start=1)}
        self._free = {i for i in self._ids.values()
                      if model.body_jntnum[i] == 1
                      and model.jnt_type[model.body_jntadr[i]] == _FREE}
        self._velocity = np.zeros(6)

    def is_free(self, name: str) -> bool:
        return self._ids[name] in self._free

    def free_qpos(self) -> list[tuple[str, int]]:
        """(name, address of its 7 numbers in qpos: position, quaternion) of each free body."""
        m = self._model
        return [(self.names[i - 1], int(m.jnt_qposadr[m.body_jntadr[i]]))
                for i in sorted(self._free)]

    def find(self, name: str) -> str:
        """The body's own name for `name` (see the module docstring); UnknownBody if none."""
        for candidate in (name, SCENE_PREFIX + name, _without_prefix(name)):
            if candidate in self._ids:
                return candidate
        raise UnknownBody(name)

    def id(self, name: str) -> int:
        return self._ids[self.find(name)]

    def check_push(self, name: str, force, torque, seconds: float) -> None:
        """Immovable if no force moves the body (`anchored`); TooViolent if a wrench held
        `seconds` on a free body would take it, from rest and unopposed, past MAX_PUSHED_SPEED
        or MAX_PUSHED_SPIN (an arm's link: its joints hold). Every engine's push asks this."""
        body = self.id(name)
        if why := self.anchored(body):
            raise Immovable(self.find(name), why)
        if body not in self._free:
            return
        m = self._model
        mass = float(m.body_subtreemass[body])
        speed = float(np.linalg.norm(force)) * seconds / mass
        spin = float(np.linalg.norm(torque)) * seconds / float(np.min(m.body_inertia[body]))
        for what, value, most, unit in (("move", speed, MAX_PUSHED_SPEED, "m/s"),
                                        ("spin", spin, MAX_PUSHED_SPIN, "rad/s")):
            if value > most:
                raise TooViolent(f"this push would {what} {self.find(name)} ({mass:g} kg) at up "
                                 f"to {value:.3g} {unit} (from rest, were nothing in its way): "
                                 f"over the {most:g} {unit} the 1 ms step integrates")

    def anchored(self, body: int) -> str:
        """Why no force moves body `body` ("" when one does): welded to the world (the
        table), or to the mobile base, a body its own motion moves (mocap: forces do not)."""
        m = self._model
        weld = m.body_weldid[body]
        if weld == 0:
            return "it is fixed to the world"
        if m.body_mocapid[weld] >= 0:
            if weld == body:
                return "only its own motion moves it"
            return f"it is carried by {self.names[weld - 1]}, which only its own motion moves"
        return ""

    def why_fixed(self, body: int) -> str:
        """Why body `body` cannot be placed: what fixes its pose."""
        return self.anchored(body) or "its pose follows its joints"

    def named_like(self, name: str) -> list[str]:
        """The bodies `name` may have meant: in a world of several arms a link is its arm's
        (`left/link7` for `link7`)."""
        tail = "/" + _without_prefix(name).rpartition("/")[2]
        return [body for body in self.names if body.endswith(tail)]

    def state(self, name: str) -> BodyState:
        """Where the body is now (the kinematics and velocities of the current state must be
        computed: mj_step1 done)."""
        body, d = self.id(name), self._data
        v = self._velocity
        mujoco.mj_objectVelocity(self._model, d, _XBODY, body, v, 0)  # [angular; linear]
        return BodyState(d.xpos[body].copy(), d.xquat[body].copy(), v[3:].copy(), v[:3].copy(),
                         body in self._free)

    def place(self, name: str, position, quaternion=None) -> None:
        """Put a free body at `position` (world frame), turned to `quaternion` (w, x, y, z; None:
        as it is), at rest. The caller recomputes what derives from the state."""
        m, d = self._model, self._data
        qpos = self.placed(name, position, quaternion, d.qpos,
                           (d.mocap_pos, d.mocap_quat) if m.nmocap else None)
        d.qpos[:] = qpos
        dof = m.jnt_dofadr[m.body_jntadr[self.id(name)]]
        d.qvel[dof:dof + 6] = 0.0
        d.qacc_warmstart[dof:dof + 6] = 0.0

    def placed(self, name: str, position, quaternion, qpos: np.ndarray, mocap=None):
        """The world's positions `qpos` (the model's layout; `mocap`: the mocap bodies' poses)
        with the free body `name` at `position` and `quaternion` (None: as it is): a copy.
        NotFree for another body; Inside where it would be inside another body, as a real
        object cannot be put (MuJoCo's contact would throw it out, Genesis's may hold it)."""
        from franka_sim.physics.intrusions import intrusions, subtree

        body = self.id(name)
        if body not in self._free:
            raise NotFree(self.find(name), self.why_fixed(body))
        m = self._model
        at = m.jnt_qposadr[m.body_jntadr[body]]
        qpos = np.array(qpos, dtype=float)
        qpos[at:at + 3] = position
        if quaternion is not None:
            quaternion = np.asarray(quaternion, dtype=float)
            quaternion = quaternion / np.abs(quaternion).max()  # (no overflow in the norm)
            qpos[at + 3:at + 7] = quaternion / np.linalg.norm(quaternion)
        if inside := intrusions(m, qpos, subtree(m, [self.find(name)]), mocap):
            raise Inside(self.find(name), inside[0])
        return qpos


class Pushes:
    """Wrenches on bodies through xfrc_applied, each for a number of steps.

    `count_down` runs at the start of every step while a push is on: a push of n steps acts
    during the n steps after it was given, and its row of xfrc_applied is zero again before
    the step after those.
    """

    def __init__(self, data: mujoco.MjData) -> None:
        self._xfrc = data.xfrc_applied
        self.steps_left: dict[int, int] = {}  # body id → steps it is still pushed for

    def push(self, body: int, force, torque, steps: int) -> None:
        """Replaces a push still acting on the same body."""
        if steps <= 0:
            raise ValueError(f"a push lasts at least one step, not {steps}")
        self._xfrc[body, :3] = force
        self._xfrc[body, 3:] = torque
        self.steps_left[body] = steps

    def count_down(self) -> None:
        left = self.steps_left
        for body, steps in list(left.items()):
            if steps == 0:
                self._xfrc[body] = 0.0
                del left[body]
            else:
                left[body] = steps - 1

    def clear(self) -> None:
        """No push any more (the data's xfrc_applied is reset by whoever resets the data)."""
        self.steps_left.clear()
