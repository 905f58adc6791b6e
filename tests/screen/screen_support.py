"""Helpers of the screen's browser tests: `ur3dq serve` in a subprocess, Debian's Chromium through Playwright, the
artifacts (screenshots, the server's log) kept for people to look at."""
from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

CHROMIUM = os.environ.get("UR3DQ_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run"]
ARTIFACTS = Path(os.environ.get("UR3DQ_TEST_ARTIFACTS", Path(__file__).resolve().parents[2] / "test-artifacts"))
SIZES = {"laptop": (1280, 800), "tablet": (800, 1280)}
URL_LINE = re.compile(r"the cell's screen is at (http://\S+)")
# A UR3 configuration clear of the floor, its singularities and limits: the tool points down over the table.
START_Q = (0.0, -1.2, 1.0, -1.4, -1.57, 0.0)


def hundred_step_store(path: Path) -> PoseStore:
    """A store of 100 UR3 poses around START_Q (a long program for the page to show while the arm moves)."""
    model = robot_model("ur3")
    poses = []
    for index in range(100):
        q = np.array(START_Q) + np.array([0.4 * math.sin(index / 7), 0.15 * math.sin(index / 5), 0.1, 0, 0, 0])
        poses.append(Pose.from_dual_quaternion(f"p{index:03d}", model.fk(q), "ur3", joints=tuple(q)))
    store = PoseStore(path)
    store.add_many(poses)
    return store


def require_browser() -> None:
    """Skip unless Playwright and the system Chromium are there (.ci/run installs Chromium where it is missing)."""
    pytest.importorskip("playwright.sync_api", reason="the browser tests need Playwright (pip install playwright)")
    if not (os.path.isfile(CHROMIUM) and os.access(CHROMIUM, os.X_OK)):
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium; .ci/run does it)")


@contextlib.contextmanager
def chromium():
    """A headless Chromium of the system (never a downloaded one), through Playwright's sync API."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()


class Served:
    """A running `ur3dq serve`: its process, URL and log file."""

    def __init__(self, process: subprocess.Popen, url: str, log: Path, started: float):
        self.process, self.url, self.log, self.started = process, url, log, started

    def log_text(self) -> str:
        return self.log.read_text(encoding="utf-8", errors="replace")


def ur3dq_command(*arguments: str, store: Path, host: str | None = None) -> list[str]:
    """The command line of `ur3dq` (this interpreter's) with a store and, if given, a robot."""
    command = [sys.executable, "-m", "ur3dq", "--store", str(store)]
    if host is not None:
        command += ["--host", host]
    return command + list(arguments)


def environment(state: Path) -> dict:
    """The environment of a subprocess: its own state directory `state` (in the test's temporary directory, so no
    background simulator is found by accident and nothing is left behind), the colour-free console."""
    state.mkdir(parents=True, exist_ok=True)
    return {**os.environ, "UR3DQ_STATE_DIR": str(state), "NO_COLOR": "1", "COLUMNS": "160"}


@contextlib.contextmanager
def served(host: str | None, store: Path, log: Path, *options: str, timeout: float = 20.0):
    """`ur3dq serve --port 0 --deg --mm` for the robot at `host`, until the block ends (SIGTERM, or it is already
    dead)."""
    log.parent.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    with open(log, "wb") as sink:
        command = ur3dq_command("serve", "--port", "0", "--deg", "--mm", *options, store=store, host=host)
        process = subprocess.Popen(command, stdout=sink, stderr=subprocess.STDOUT,
                                   env=environment(log.parent / "state"))
    try:
        url = None
        deadline = time.monotonic() + timeout
        while url is None:
            match = URL_LINE.search(log.read_text(encoding="utf-8", errors="replace"))
            url = match.group(1) if match else None
            if url is None:
                assert process.poll() is None, f"ur3dq serve ended: {log.read_text()}"
                assert time.monotonic() < deadline, f"ur3dq serve printed no URL: {log.read_text()}"
                time.sleep(0.01)
        yield Served(process, url, log, started)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@contextlib.contextmanager
def page_on_powered_arm(browser, store: Path, log: Path):
    """(page, simulator, server): a 1280×800 page on `ur3dq serve` (served) against a powered simulator at START_Q,
    once the server says it is ready; the page is closed after the block."""
    from polling import wait_for
    from powered_simulator import powered_simulator

    page = browser.new_page(viewport={"width": 1280, "height": 800})
    try:
        with powered_simulator(initial_q=",".join(map(str, START_Q))) as simulator, \
                served(simulator.host, store, log) as server:
            page.goto(server.url)
            assert wait_for(lambda: "; ready" in server.log_text(), timeout=30), server.log_text()
            yield page, simulator, server
    finally:
        page.close()


def button(page, name: str):
    """The page's button whose accessible name is exactly `name`."""
    return page.get_by_role("button", name=name, exact=True)


def readout_radians(text: str) -> float:
    """A joint readout ('12.34 °' or '0.2154 rad') in radians."""
    number, unit = text.split()
    return math.radians(float(number)) if unit == "°" else float(number)


def screenshots(page, name: str, showing: str | None = None) -> list[Path]:
    """Screenshots of `page` at the laptop and tablet sizes, as test artifacts (the viewport is put back), with the
    element `showing` (a selector) scrolled to the top of its panel."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    before = page.viewport_size
    saved = []
    for size_name, (width, height) in SIZES.items():
        page.set_viewport_size({"width": width, "height": height})
        page.wait_for_timeout(300)   # the layout and the 3D view follow the new size
        if showing is not None:
            page.locator(showing).evaluate("element => element.scrollIntoView({block: 'start'})")
        path = ARTIFACTS / f"screen-{name}-{size_name}.png"
        page.screenshot(path=str(path))
        saved.append(path)
    page.set_viewport_size(before)
    return saved


def keep_artifact(path: Path) -> Path:
    """A copy of `path` among the test artifacts."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return Path(shutil.copy(path, ARTIFACTS / path.name))


def expect(locator):
    """Playwright's web-first assertions on `locator` (imported when a test first uses them)."""
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(locator)


def hold(page, name: str, seconds: float) -> None:
    """Hold the (enabled) button `name` pressed with the mouse for `seconds`, then release it."""
    expect(button(page, name)).to_be_enabled(timeout=10000)
    button(page, name).hover()
    page.mouse.down()
    time.sleep(seconds)
    page.mouse.up()


def notice_after(page, click, starts: str, timeout: float = 30.0, server: Served | None = None) -> str:
    """Click, then wait until the page's notice line starts with `starts`; that line. With `server`, a notice that
    never comes fails with the server's log and the stack of its every thread (a hang says where it hangs)."""
    from playwright.sync_api import TimeoutError as PageTimeout

    page.evaluate("document.getElementById('notice').textContent = ''")
    click()
    try:
        page.wait_for_function(f"document.getElementById('notice').textContent.startsWith({json.dumps(starts)}) || "
                               "document.getElementById('notice').textContent.startsWith('Error')",
                               timeout=timeout * 1000)
    except PageTimeout:
        if server is None:
            raise
        server.process.send_signal(signal.SIGQUIT)   # ur3dq prints every thread's stack (ur3dq.cli.signals)
        time.sleep(1.0)
        raise AssertionError(f"no notice {starts!r} within {timeout:g} s; the server's log, with its threads' "
                             f"stacks:\n{server.log_text()[-12000:]}") from None
    return page.locator("#notice").text_content()


def set_speed_slider(page, percent: int) -> None:
    """Set the page's speed slider (the controller's speed scaling) and wait until the page shows it."""
    page.locator("#speed-slider").fill(str(percent))
    page.wait_for_function(f"document.getElementById('speed-value').textContent === '{percent} %'", timeout=5000)


def insert_gripper_and_wait(page, after: str, wait: str) -> None:
    """Select step `after`, add the tool output 0 (the gripper) on after it, then a wait of `wait` (as typed) after
    that output."""
    page.locator(f'[data-step="{after}"]').click()
    button(page, "Add output").click()
    page.locator("#ask select[name=group]").select_option("tool")
    button(page, "OK").click()
    expect(page.locator('[data-step="output-1"]')).to_have_count(1)
    button(page, "Add wait").click()
    page.locator("#ask input[name=seconds]").fill(wait)
    button(page, "OK").click()
    expect(page.locator('[data-step="wait-1"]')).to_have_count(1)
