"""`franka-sim view RECORDING` in a real browser: the timeline scrubbed to a moment shows the
state recorded there (a committed recording of libfranka's own example, no client needed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.recording.reader import open_recording
from franka_sim.testing import fresh_loopback_address
from support.browser import console_errors, headless_chromium, readouts, screenshot, wait_for

pytest.importorskip("viser", reason="the web view needs franka-sim[web] (viser)")

RECORDING = (Path(__file__).resolve().parents[1] / "data" / "older_libfranka" / "0.13.6"
             / "generate_joint_position_motion.mcap")
PORT = 8080


@pytest.fixture(scope="module")
def viewed():
    host = fresh_loopback_address()
    proc = subprocess.Popen([sys.executable, "-m", "franka_sim", "view", str(RECORDING),
                             "--host", host, "--port", str(PORT)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert "Ctrl-C ends" in line, proc.stderr.read() if proc.poll() is not None else line
    yield host
    proc.terminate()
    assert proc.wait(10) == 0  # (SIGTERM ends it as Ctrl-C does, as it ends serve)


def span() -> tuple[int, int]:
    """The cycles the view's timeline spans: the recording's, from its first pose of the world
    to its last state or pose."""
    recording = open_recording(RECORDING)
    ids = recording.states()["message_id"].astype(np.int64)
    poses = [e.json()["cycle"] for e in recording.of("bodies")]
    return min(ids[0], *poses), max(ids[-1], *poses)


def expected_q(seconds: float) -> str:
    states = open_recording(RECORDING).states()
    ids = states["message_id"].astype(np.int64)
    i = min(int(ids.searchsorted(span()[0] + round(seconds * 1000))), len(ids) - 1)
    return " ".join(f"{v:.4f}" for v in states["q"][i])


def test_scrubbing_the_timeline_shows_the_recorded_state_there(viewed):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    with headless_chromium() as browser:
        browser.get(f"http://{viewed}:{PORT}/")
        wait_for(lambda: readouts(browser).get("q (rad)", "-") != "-", 60, "the first state")
        assert readouts(browser)["q (rad)"] == expected_q(0.0)
        before = screenshot(browser)
        first, last = span()
        moment = round((last - first) / 1000 / 2, 3)  # the middle
        box = next(i for i in browser.find_elements(By.CSS_SELECTOR, "input")
                   if i.get_attribute("value") == "0" and i.get_attribute("type") != "hidden")
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys(str(moment), Keys.ENTER)
        wait_for(lambda: readouts(browser).get("q (rad)") == expected_q(moment), 30,
                 f"the state recorded at {moment} s")
        assert expected_q(moment) != expected_q(0.0)  # (the arm moved meanwhile)
        after = screenshot(browser)
        assert np.abs(before.astype(int) - after.astype(int)).max(axis=2).__gt__(40).sum() > 200
        # a time past the recording's end: the box goes back to the end, which it shows
        end = round((last - first) / 1000, 3)
        box.send_keys(Keys.CONTROL, "a")
        box.send_keys(str(end + 100), Keys.ENTER)
        wait_for(lambda: box.get_attribute("value") == f"{end:g}", 30,
                 f"the box back at the end, {end} s")
        wait_for(lambda: readouts(browser).get("q (rad)") == expected_q(end), 30,
                 "the last state recorded")
        assert console_errors(browser) == []
