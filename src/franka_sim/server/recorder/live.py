"""Recording a world: from its start (`franka-sim serve --record`), or started and finished on a
running simulator (the control API's `/recording`).

Either way a Recorder is attached to the world's taps (server/recorder/taps.py) between two
cycles, in the cycle thread, and taken off the same way. A recording started through the
control API begins with the reset that starts it (recorded as a control call at the cycle
where it ran) and its metadata says so (`start: reset`): replay builds a fresh simulator,
moves its clock to that cycle and resets it there, and a reset world is a fresh one at a later
message_id. So only a world whose reset is a whole world's can be recorded that way: one arm
(a reset of one robot of several leaves the others as they are).
"""

from __future__ import annotations

from pathlib import Path

from franka_sim.control.errors import Conflict
from franka_sim.recording.metadata import START_FRESH, START_RESET, describe


class Recordings:
    """The recordings of `sim` (a FrankaSim): its taps, its world's cycle, its robots."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self.live = None  # the recording the control API started, while it runs

    def refused(self) -> str | None:
        """Why this simulator's runs cannot be recorded through the control API (None: they
        can): a recording replays on MuJoCo, so another engine's is refused, as `serve
        --record` is."""
        engine = self.sim.config.physics
        if engine != "mujoco":
            return (f"the {engine} engine's runs are not recorded: a recording replays on "
                    "MuJoCo (docs/engines.md), as `serve --record` is refused with it")
        return None

    def in_the_way(self):
        """The recording a new one must wait for (None: none): one under way, or one started
        here that failed and is not finished yet (DELETE /recording says why). A `serve
        --record` that failed (a full disk) makes way."""
        recorder = self.sim.taps.recorder
        if recorder is None or (recorder.failure is not None and recorder is not self.live):
            return None
        return recorder

    def open(self, path: str | Path, start: str = START_RESET):
        """A Recorder writing to `path` (OSError: it cannot), not yet attached."""
        from franka_sim.server.recorder.recorder import Recorder  # mcap: only when recording

        sim = self.sim
        metadata = describe(sim.config, sim.urdf_text, sim.scene, sim.parts.robots)
        metadata["start"] = start
        return Recorder(Path(path).absolute(), metadata,
                        [robot.name for robot in sim.parts.robots])

    def attach(self, recorder, world, *, cycle=None, fresh: bool = False) -> None:
        """Cycle thread, lock held, between two cycles: tap the world (physics/world.py; `cycle`:
        its cycle, the driver's by default) and, unless `fresh` (the world's first cycle: its server starts
        the writer), start writing. Conflict while a client is connected to a recording that
        starts from a reset."""
        sim = self.sim
        if not fresh:
            connected = [what for robot in sim.robots
                         for what, endpoint in (("an FCI client", robot.fci),
                                                ("a Hand client", robot.tool_endpoint))
                         if endpoint is not None and endpoint.active is not None]
            if connected:
                raise Conflict(f"{' and '.join(connected)} connected: a recording starts with "
                               "none (it begins from a reset world, without their sessions)")
        recorder.describe_world(world.bodies.free_qpos())
        if sim.taps.recorder is not None:  # serve --record's, failed (`in_the_way`)
            sim.taps.detach()
        sim.taps.attach(recorder, cycle or sim.driver.cycle, world.positions())
        if not fresh:
            recorder.start()
            self.live = recorder

    def detach(self):
        """Cycle thread, lock held: take the taps off; the Recorder, still to be stopped."""
        if self.live is None:
            raise Conflict("no recording started through the control API is under way")
        self.live = None
        return self.sim.taps.detach()

    def discard(self, recorder) -> None:
        """A recording whose start was refused or failed: closed, its file removed (one never
        started leaves the target as it was)."""
        if self.sim.taps.recorder is recorder:
            self.sim.taps.detach()
        self.live = None
        recorder.stop()
        if recorder.started and recorder.path.is_file():  # (a device, /dev/null, stays)
            recorder.path.unlink(missing_ok=True)

    def close(self) -> None:
        """The simulator stops: a recording still under way is finished (a complete file),
        and so is `serve --record`'s, attached or not."""
        if self.sim.taps.recorder is not None:
            self.sim.taps.detach().stop()
        if self.sim.recorder is not None:
            self.sim.recorder.stop()


__all__ = ["START_FRESH", "START_RESET", "Recordings"]
