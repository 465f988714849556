"""Where a recording says the world was at a cycle: each arm at its state sent nearest that
cycle, the free bodies and the Hand's fingers at the world's last pose record before it, the
mobile base where its own last state had it. `render` draws it frame by frame, and `view`
(web/recording_view.py) shows it as the timeline is scrubbed.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.protocol.codec import STATE_DTYPE


def recorded_physics(recording, workdir: str, meshes=None):
    """(config, parts, physics) of the world `recording` was made in, built from its metadata
    (`workdir`: where a recorded URDF or scene is written; `meshes`: how it is drawn).
    Incompatible where this franka-sim cannot build it (a recorded URDF it cannot read);
    SceneError for --meshes or a recorded scene."""
    from franka_sim.assembly import WorldParts
    from franka_sim.description.urdf import DescriptionError
    from franka_sim.recording.metadata import Incompatible, replay_config

    config = replay_config(recording.metadata, workdir)
    config.meshes = meshes
    try:
        parts = WorldParts(config)
        return config, parts, parts.make_physics()
    except DescriptionError as exc:
        raise Incompatible(f"the recorded world cannot be built: {exc}") from None


class RecordedWorld:
    """`recording` over `physics` (the world it was made in, built from its metadata):
    `arms`, `names`, each arm's `states` and their `ids`, and `first` / `last`, the cycles it
    spans."""

    def __init__(self, recording, physics) -> None:
        world = physics.world
        self.model = world.model
        self._qpos0 = world.data.qpos.copy()
        self._mocap = (world.data.mocap_pos.copy(), world.data.mocap_quat.copy())
        self.arms = list(world.arms.values())
        self.names = recording.robots[:len(self.arms)]
        self.states = [recording.states(name) for name in self.names]
        self.ids = [s["message_id"].astype(np.int64) for s in self.states]
        poses = [(e.json()["cycle"], np.array(e.json()["qpos"])) for e in recording.of("bodies")]
        self._poses = [(c, q) for c, q in poses if len(q) == self.model.nq]
        self._pose_cycles = np.array([c for c, _ in self._poses], dtype=np.int64)
        self._base = _BasePoses(recording, self.model, len(self.arms))
        # Its span: the arms' and the base's states and the world's poses (a Hand acting after
        # the arms' last state, or alone, moves its fingers there).
        spans = [ids for ids in (*self.ids, self._base.ids, self._pose_cycles) if len(ids)]
        if not spans:
            from franka_sim.recording.metadata import Incompatible

            raise Incompatible("nothing to show: no arm state and no pose of the world recorded")
        self.first = int(min(ids[0] for ids in spans))
        self.last = int(max(ids[-1] for ids in spans))

    def at_cycle(self, cycle: int) -> tuple[np.ndarray, tuple, np.ndarray, np.ndarray]:
        """(qpos, each arm's RobotState bytes sent nearest `cycle` (None: it has none),
        mocap_pos, mocap_quat) at `cycle`: copies."""
        k = self._pose_cycles.searchsorted(cycle, side="right") - 1
        qpos = self._poses[k][1].copy() if k >= 0 else self._qpos0.copy()
        sent = []
        for arm, states, ids in zip(self.arms, self.states, self.ids):
            if len(ids) == 0:
                sent.append(None)
                continue
            i = min(int(ids.searchsorted(cycle)), len(ids) - 1)
            qpos[arm.qs] = states["q"][i]
            sent.append(states[i].tobytes())
        return (qpos, tuple(sent), *self._base.at(cycle, *self._mocap))

    def put(self, data, cycle: int) -> None:
        """The world at `cycle` into `data` (positions only: mj_forward follows)."""
        qpos, _, mocap_pos, mocap_quat = self.at_cycle(cycle)
        data.qpos[:], data.mocap_pos[:], data.mocap_quat[:] = qpos, mocap_pos, mocap_quat


class _BasePoses:
    """The mobile base's pose as recorded: it is a mocap body, not in the world's qpos, and
    its own states (its odometry in O_T_EE, from where it started: the world origin) say
    where it stood. None recorded (no base, or no client of it): the start's."""

    def __init__(self, recording, model, arms: int) -> None:
        from franka_sim.physics.mobile_base import BASE_BODY

        names = recording.robots[arms:]
        states = recording.states(names[0]) if names else np.zeros(0, STATE_DTYPE)
        self.ids = states["message_id"].astype(np.int64)
        T = states["O_T_EE"].reshape(-1, 4, 4).transpose(0, 2, 1)  # (column-major on the wire)
        self._x, self._y = T[:, 0, 3], T[:, 1, 3]
        self._yaw = np.arctan2(T[:, 1, 0], T[:, 0, 0])
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, BASE_BODY)
        self._mocap = int(model.body_mocapid[body]) if body >= 0 else -1

    def at(self, cycle: int, mocap_pos, mocap_quat) -> tuple:
        """(mocap_pos, mocap_quat) at `cycle`: copies of the start's, the base put where its
        last state by then had it."""
        pos, quat = mocap_pos.copy(), mocap_quat.copy()
        i = int(self.ids.searchsorted(cycle, side="right")) - 1
        if i >= 0 and self._mocap >= 0:
            m, yaw = self._mocap, float(self._yaw[i])
            pos[m, 0], pos[m, 1] = self._x[i], self._y[i]
            quat[m] = (np.cos(0.5 * yaw), 0.0, 0.0, np.sin(0.5 * yaw))
        return pos, quat
