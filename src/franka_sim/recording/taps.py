"""A FrankaSim's recorder: opened with the simulator, its taps set on the endpoints."""

from __future__ import annotations

import logging

from franka_sim.recording.metadata import describe
from franka_sim.recording.recorder import Recorder


def install_recorder(sim) -> Recorder:
    """Open `sim.config.record` (OSError: it cannot be written) and tap the simulator."""
    recorder = Recorder(sim.config.record, describe(sim.config, sim.urdf_text, sim.scene))
    sim.udp.recorder = recorder
    sim.robot.recorder = recorder
    sim.gripper_endpoint.recorder = recorder
    sim.control.recorder = recorder
    logging.getLogger().addHandler(recorder.log_handler())
    return recorder
