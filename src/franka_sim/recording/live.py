"""Recordings started and finished on a running simulator (the control API's `/recording`).

`franka-sim serve --record` taps a simulator before it serves; here the taps are set between
two cycles, in the cycle thread's job that also resets the world, and taken off the same way.
Such a recording begins with that reset (recorded as a control call at the cycle where it ran)
and its metadata says so (`start: reset`): replay builds a fresh simulator, moves its clock to
that cycle and resets it there, and a reset world is a fresh one at a later message_id.
"""

from __future__ import annotations

import logging
from pathlib import Path

from franka_sim.control.errors import Conflict

START_FRESH, START_RESET = "fresh", "reset"  # the metadata's `start`


class LiveRecordings:
    """The one arm of `sim` (a FrankaSim), recorded on demand; one recording at a time."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self.live = None  # the Recorder under way

    def open(self, path: str):
        """A Recorder writing to `path` (OSError: it cannot), not yet tapping anything."""
        from franka_sim.recording.metadata import describe
        from franka_sim.recording.recorder import Recorder

        sim = self.sim
        metadata = describe(sim.config, sim.urdf_text, sim.scene)
        metadata["start"] = START_RESET
        return Recorder(Path(path).absolute(), metadata)

    def attach(self, recorder, physics) -> None:
        """Cycle thread, lock held, between two cycles: tap the simulator and start writing."""
        sim = self.sim
        connected = [what for what, endpoint in (("an FCI client", sim.robot),
                                                 ("a Hand client", sim.gripper_endpoint))
                     if endpoint.active is not None]
        if connected:
            raise Conflict(f"{' and '.join(connected)} connected: a recording starts with none "
                           "(it begins from a reset world, without their sessions)")
        cycle = sim.driver.cycle
        recorder.attach(cycle, physics)
        self._set_taps(cycle, recorder)
        logging.getLogger().addHandler(recorder.log_handler())  # removed by its stop
        recorder.start()
        self.live = recorder

    def detach(self):
        """Cycle thread, lock held: take the taps off; the Recorder, still to be stopped."""
        recorder = self.live
        if recorder is None:
            raise Conflict("no recording started through the control API is under way")
        self._set_taps(self.sim.driver.cycle, None)
        self.live = None
        return recorder

    def discard(self, recorder) -> None:
        """A recording whose start was refused or failed: closed, its file removed."""
        if self.live is recorder:
            self._set_taps(self.sim.driver.cycle, None)
            self.live = None
        recorder.stop()
        recorder.path.unlink(missing_ok=True)

    def close(self) -> None:
        """The simulator stops: a recording still under way is finished (a complete file)."""
        recorder, self.live = self.live, None
        if recorder is not None:
            self._set_taps(self.sim.driver.cycle, None)
            recorder.stop()

    def _set_taps(self, cycle, recorder) -> None:
        sim = self.sim
        sim.udp.recorder = recorder
        sim.robot.recorder = recorder
        sim.gripper_endpoint.recorder = recorder
        sim.control.recorder = recorder
        if cycle is not None:
            cycle.recorder = recorder
