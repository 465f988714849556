"""The web view in a real browser (Debian's headless chromium): the page loads without console
errors, the 3D view shows the arm, a pylibfranka client's motions move it on screen, and the
side panel's readouts say what the control API's /state says."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from franka_sim.config import READY_POSE
from franka_sim.control import Control
from franka_sim.testing import running_sim
from support.browser import (console_errors, headless_chromium, readouts, screenshot,
                             wait_for)

pytest.importorskip("viser", reason="the web view needs franka-sim[web] (viser)")

WEB_PORT = 8080
DIGITS = 4  # the readouts' decimals (web/arm_panel.py)
LINK_WHITE = 200  # a link's pixels are at least this bright in every channel
CHANGED = 40  # a pixel moved when a channel changed by more than this

# A pylibfranka client in a child Python (its blocking calls hold the GIL, which would stall
# this process's browser calls): each line of 7 numbers read is a motion there, "moved" after.
CLIENT = """
import sys
from support.clients import connect, move_to
robot = connect(sys.argv[1])
print("connected", flush=True)
for line in sys.stdin:
    move_to(robot, [float(v) for v in line.split()], seconds=1.5)
    print("moved", flush=True)
"""


class Client:
    def __init__(self, host: str) -> None:
        tests = Path(__file__).resolve().parents[1]
        self.proc = subprocess.Popen([sys.executable, "-c", CLIENT, host], text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     env={"PYTHONPATH": str(tests), "PATH": "/usr/bin:/bin"})
        assert self.proc.stdout.readline().strip() == "connected"

    def move(self, q) -> None:
        self.proc.stdin.write(" ".join(f"{v:.6f}" for v in q) + "\n")
        self.proc.stdin.flush()
        said = self.proc.stdout.readline().strip()
        assert said == "moved", f"the client did not finish its motion: {said!r}"

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(20)


@pytest.fixture(scope="module")
def served():
    with running_sim("--web", str(WEB_PORT)) as server:
        yield server


@pytest.fixture(scope="module")
def page(served):
    with headless_chromium() as browser:
        browser.get(f"http://{served.host}:{WEB_PORT}/")
        wait_for(lambda: "robot mode" in readouts(browser), 60, "the side panel")
        yield browser


def view_of(image: np.ndarray) -> np.ndarray:
    """The 3D view's part of a screenshot: left of the side panel, below the notices."""
    height, width, _ = image.shape
    return image[height // 5:, : int(width * 0.6)].astype(int)


def link_pixels(image: np.ndarray) -> np.ndarray:
    """Where the view shows the arm's white links (bright, hardly coloured)."""
    bright = image.min(axis=2) >= LINK_WHITE
    grey = image.max(axis=2) - image.min(axis=2) <= 12
    return bright & grey & (image.min(axis=2) < 254)  # (not the white page behind)


def shown_q(browser) -> list[float] | None:
    text = readouts(browser).get("q (rad)", "")
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        return None
    return values if len(values) == 7 else None


def shows_state(browser, host: str):
    """The readouts once they say what /state says (None until then)."""
    state = Control(host).state()
    shown = readouts(browser)
    expected = " ".join(f"{v:.{DIGITS}f}" for v in state["q"])
    if shown.get("q (rad)") == expected and shown.get("robot mode") == state["robot_mode"]:
        return shown
    return None


def test_page_loads_without_console_errors_and_shows_the_arm(page, served):
    assert console_errors(page) == []
    view = view_of(screenshot(page))
    assert len(np.unique(view.reshape(-1, 3), axis=0)) > 50, "the 3D view is blank"
    assert link_pixels(view).sum() > 500, "no white link in the 3D view"
    assert served.log_matching("a web watcher connected")


def test_motions_move_the_arm_on_screen_and_the_readouts_match_state(page, served):
    client = Client(served.host)
    try:
        turned = list(READY_POSE)
        turned[0] += 0.8  # joint 1: the whole arm swings round
        client.move(READY_POSE)
        wait_for(lambda: shows_state(page, served.host), 30, "the readouts to match /state")
        before = view_of(screenshot(page))
        client.move(turned)
        shown = wait_for(lambda: shows_state(page, served.host), 30,
                         "the readouts to match /state after the motion")
        after = view_of(screenshot(page))
    finally:
        client.close()
    assert abs(shown_q(page)[0] - turned[0]) < 1e-3
    assert shown["robot mode"] == "Idle" and shown["errors"] == "none"
    changed = np.abs(before - after).max(axis=2) > CHANGED
    assert changed.sum() > 500, "the arm did not move on screen"
    # What changed is where the arm was or now is: within its links' extent, before or after.
    arm = link_pixels(before) | link_pixels(after)
    rows, cols = np.nonzero(arm)
    box = np.zeros_like(arm)
    margin = 40
    box[max(rows.min() - margin, 0):rows.max() + margin,
        max(cols.min() - margin, 0):cols.max() + margin] = True
    assert changed[box].sum() >= 0.9 * changed.sum(), "pixels changed away from the arm"
    assert console_errors(page) == []
    wait_for(lambda: plot_has_lines(page, "q vs q_d (rad)"), 120,
             "the q plot to draw its lines")  # (its next update, however busy the machine)


# Each uPlot's time data and the time span its axis shows (viser's test hooks on the page).
CHARTS = """const charts = (window.__viserTestpoints || {}).uplots || {};
return Object.values(charts).map(({chart}) => {const x = chart.data[0];
  return [x[0], x[x.length - 1], chart.scales.x.min, chart.scales.x.max];});"""


def test_every_plots_time_axis_follows_its_data_after_a_motion(page, served):
    """A motion changes some plots' y scale (a success rate of 0 becomes 1): each plot still
    shows its whole window up to the latest state, not the time span it had then."""
    def shown_for(seconds):
        charts = page.execute_script(CHARTS)
        return charts if charts and min(x1 for _, x1, _, _ in charts) >= seconds else None
    start = max(x1 for _, x1, _, _ in wait_for(lambda: shown_for(0.0), 60, "the plots"))
    wait_for(lambda: shown_for(start + 3.0), 60, "the plots to go on while idle")
    client = Client(served.host)
    try:
        turned = list(READY_POSE)
        turned[3] += 0.3
        client.move(turned)
        client.move(READY_POSE)
    finally:
        client.close()

    def following():
        charts = page.execute_script(CHARTS)
        if len(charts) < 4 or min(x1 for _, x1, _, _ in charts) < start + 8.0:
            return None  # (3 s idle, the motions' 3 s and 2 s after them, shown)
        if all(abs(shown_from - x0) < 0.5 and abs(shown_to - x1) < 0.5
               for x0, x1, shown_from, shown_to in charts):
            return charts
        return None
    wait_for(following, 60, "every plot's time axis to show its data's window")


def plot_has_lines(browser, title: str) -> bool:
    """The uPlot of that title shows its series' colours (web/arm_panel.py's strokes)."""
    from PIL import Image
    import io

    from selenium.webdriver.common.by import By

    for plot in browser.find_elements(By.CSS_SELECTOR, ".uplot"):
        if title in plot.text:
            browser.execute_script("arguments[0].scrollIntoView()", plot)
            image = np.asarray(Image.open(io.BytesIO(plot.screenshot_as_png)).convert("RGB"))
            image = image[: int(image.shape[0] * 0.75)].astype(int)  # (not the legend's keys)
            # (60: a flat line's one row of pixels, blended with the white behind it)
            blue = (np.abs(image - (0x1F, 0x77, 0xB4)).max(axis=2) < 60).sum()
            orange = (np.abs(image - (0xFF, 0x7F, 0x0E)).max(axis=2) < 60).sum()
            return blue + orange > 100
    return False


def test_a_watcher_who_comes_after_the_client_left_sees_the_arm_as_it_is():
    """The clock paused with nobody connected: the page shows the state the robot publishes
    (what the last client was told, what the next will read first), not an empty panel, and
    its plots draw that state held."""
    with running_sim("--web", str(WEB_PORT), "--clock", "lockstep") as server:
        client = Client(server.host)
        try:
            turned = list(READY_POSE)
            turned[0] += 0.3  # (joint 1's plot: a line held off its axis)
            turned[1] += 0.3
            client.move(turned)
        finally:
            client.close()
        control = Control(server.host)
        wait_for(lambda: not control.health()["client_connected"], 30, "the client to leave")
        with headless_chromium() as browser:
            browser.get(f"http://{server.host}:{WEB_PORT}/")
            shown = wait_for(lambda: shows_state(browser, server.host), 60,
                             "the readouts to say what /state says")
            assert abs(shown_q(browser)[1] - turned[1]) < 1e-3
            assert shown["robot mode"] == "Idle"
            wait_for(lambda: plot_has_lines(browser, "q vs q_d (rad)"), 60,
                     "the q plot to draw the state held")  # (no state follows it)


def test_an_embedded_simulator_started_again_on_its_web_port_serves_the_open_page():
    """Leaving `async with FrankaSim(web_port=...)` with a page open and entering it again in
    the same process: the port is free at once, and the open page reconnects to the new one."""
    import asyncio

    from franka_sim.server.sim import FrankaSim
    from franka_sim.testing import fresh_loopback_address

    host = fresh_loopback_address()

    async def watched(browser, open_page: bool) -> None:
        async with FrankaSim(host=host, control_port=0, web_port=WEB_PORT) as sim:
            if open_page:
                await asyncio.to_thread(browser.get, f"http://{host}:{WEB_PORT}/")
            await asyncio.to_thread(wait_for, lambda: sim.web.watchers == 1, 60,
                                    "the page to connect")
            await asyncio.to_thread(wait_for, lambda: "robot mode" in readouts(browser), 60,
                                    "the side panel")

    with headless_chromium() as browser:
        asyncio.run(watched(browser, open_page=True))
        asyncio.run(watched(browser, open_page=False))
