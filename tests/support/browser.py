"""A real headless browser for tests of the web view: Debian's chromium driven through its
chromedriver by selenium, on SwiftShader's software WebGL (no GPU, no display). Skips, saying
what to install, where the browser or its driver is missing (.ci/run installs both)."""

from __future__ import annotations

import contextlib
import io
import shutil
import time

import numpy as np
import pytest

WINDOW = (1280, 800)


def _browser_paths() -> tuple[str, str]:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if chromium is None or driver is None:
        pytest.skip("the web view's tests need a headless browser: Debian's chromium and "
                    "chromium-driver are not installed (apt-get install chromium chromium-driver)")
    return chromium, driver


@contextlib.contextmanager
def headless_chromium():
    """A selenium WebDriver on a fresh headless chromium for the block."""
    chromium, driver = _browser_paths()
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                f"--window-size={WINDOW[0]},{WINDOW[1]}", "--use-gl=angle",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--disable-background-networking", "--no-first-run"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    browser = webdriver.Chrome(service=Service(driver), options=options)
    try:
        yield browser
    finally:
        browser.quit()


def console_errors(browser) -> list[str]:
    """The console's errors since the last call (SEVERE entries: uncaught exceptions, failed
    loads, console.error)."""
    return [entry["message"] for entry in browser.get_log("browser")
            if entry["level"] == "SEVERE"]


def screenshot(browser) -> np.ndarray:
    """The page as an RGB array (height, width, 3)."""
    from PIL import Image

    png = browser.get_screenshot_as_png()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


# Each text readout of the side panel by its label: viser writes a label beside its input.
_READOUTS_JS = """
const found = {};
for (const input of document.querySelectorAll('input')) {
  let node = input, label = null;
  for (let up = 0; up < 6 && node && !label; up++) {
    node = node.parentElement;
    if (!node) break;
    const candidate = node.querySelector('label, p, span');
    if (candidate && candidate.innerText && !candidate.contains(input)) label = candidate;
  }
  if (label) found[label.innerText.trim()] = input.value;
}
return found;
"""


def readouts(browser) -> dict[str, str]:
    return browser.execute_script(_READOUTS_JS)


def wait_for(predicate, timeout: float, what: str):
    """predicate()'s first truthy value, polled; AssertionError naming `what` after timeout."""
    end = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)
