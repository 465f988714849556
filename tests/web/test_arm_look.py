"""The arm looks like an FR3 in a render: a frame of examples/pick_and_place.py's recording
shows white link housings, dark joint caps and the Hand, in their materials' colours, and
none of the collision envelopes (physics/arm_look.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.physics.arm_look import CAP_RGBA, COLLISION_GROUP, LINK_RGBA, VISUAL_GROUP
from franka_sim.testing import running_sim
from support.rendering import render_frame

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "pick_and_place.py"


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    pytest.importorskip("mcap")
    path = tmp_path_factory.mktemp("look") / "pick_and_place.mcap"
    with running_sim("--clock", "lockstep", "--record", str(path)) as server:
        done = subprocess.run([sys.executable, str(EXAMPLE), server.host], capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, done.stderr
    return path


def _geoms_named(names, pattern) -> set[int]:
    return {g for g, name in enumerate(names) if pattern(name)}


def test_a_frame_shows_the_links_white_the_caps_dark_and_no_collision_envelope(recording,
                                                                              tmp_path):
    rgb, geom, names, groups = render_frame(recording, tmp_path, which=0.5)  # cube carried
    links = _geoms_named(names, lambda n: "_visual" in n and n.startswith("link"))
    caps = _geoms_named(names, lambda n: n.endswith("_cap"))
    hand = _geoms_named(names, lambda n: n.startswith("hand_visual"))
    envelopes = {g for g in range(len(names)) if groups[g] == COLLISION_GROUP}
    assert links and caps and hand and envelopes
    assert all(groups[g] == VISUAL_GROUP for g in links | caps | hand)
    shown = set(np.unique(geom)) - {-1}
    assert not shown & envelopes, "a collision envelope is drawn"
    for name, ids, material in (("links", links, LINK_RGBA), ("caps", caps, CAP_RGBA),
                                ("the Hand", hand, LINK_RGBA)):
        mask = np.isin(geom, list(ids))
        assert mask.sum() > 100, f"{name} hardly visible"
        median = np.median(rgb[mask].astype(float), axis=0)
        expected = 255 * np.asarray(material[:3])
        # Lit and shaded, a surface keeps its material's hue: a grey as grey, its brightness
        # on the material's side of the scene's mid grey.
        assert median.max() - median.min() < 12, (name, median)
        if expected.mean() > 128:
            assert median.mean() > 150, (name, median)
        else:
            assert median.mean() < 70, (name, median)
