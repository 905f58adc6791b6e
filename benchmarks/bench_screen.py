"""The cell's screen (`ur3dq serve`) against its goals, in a real headless Chromium and a simulator process.

Figures, each printed beside its goal and the machine's 1-minute load average (which they follow):
  - page load: `ur3dq serve` starting → the page's first drawn arm (`window.ur3dqScreen.firstArmDrawnAt`), a new
    simulator each run; goal ≤ 1.5 s (median of --runs);
  - live-view latency: the simulated arm's joint 1 passing a value (its RTDE timestamps, read with ur_rtde) → the
    page's readout showing it (a MutationObserver's timestamp); goals ≤ 100 ms median, ≤ 250 ms p99;
  - readouts and 3D frames a second while the arm moves, with a 100-step program shown; goal ≥ 20 readouts/s;
  - server → page delivery delay of the states (median, p99): where the latency's tail comes from.

Debian's Chromium (/usr/bin/chromium, or $UR3DQ_CHROMIUM) through Playwright, with no GPU (SwiftShader draws
WebGL); the server, the simulator and the browser share the machine's cores. The figures are also written as JSON
(--json, default test-artifacts/screen-timing.json) for docs/performance.md.

Run: .venv/bin/python benchmarks/bench_screen.py [--runs 3] [--json PATH]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import rtde_receive
from playwright.sync_api import Browser, sync_playwright

import ur3dq.robot
from sim_ursim.launch import simulator_process

# The same simulator, server and program as the screen's tests (tests/screen/screen_support.py).
TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path[:0] = [str(TESTS), str(TESTS / "screen")]
from powered_simulator import powered_simulator  # noqa: E402
from screen_support import CHROMIUM, CHROMIUM_ARGS, START_Q, hundred_step_store, served  # noqa: E402

GOALS = {"page_load_s": ("≤", 1.5), "latency_median_ms": ("≤", 100.0), "latency_p99_ms": ("≤", 250.0),
         "readout_updates_per_s": ("≥", 20.0)}
# Every change of joint 1's readout, with the time the page showed it (ms since the epoch, as time.time() * 1000).
WATCH_READOUT = """() => { window.readouts = [];
  const readout = document.querySelector('[data-joint="0"]');
  new MutationObserver(() => window.readouts.push([performance.timeOrigin + performance.now(), readout.textContent]))
    .observe(readout, {childList: true, characterData: true, subtree: true}); }"""


def page_load(browser: Browser, folder: Path) -> float:
    """Seconds from `ur3dq serve` starting to the page's first drawn arm (a new simulator, the page opened as soon
    as the server prints its URL)."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    with simulator_process(model="ur3", initial_q=list(START_Q)) as simulator:
        started = time.time()
        with served(simulator.host, folder / "poses.json", folder / "serve-load.log") as server:
            page.goto(server.url)
            page.wait_for_function("document.body.dataset.armDrawn === 'true'", timeout=20000)
            drawn = page.evaluate("window.ur3dqScreen.firstArmDrawnAt") / 1000.0
    page.close()
    return float(drawn - started)


def moves_watched(host: str) -> tuple[list[tuple[float, float, float]], list[tuple[float, float]]]:
    """Three movej of joint 1 (0.8 rad out, back, out) at 0.4 rad/s, with ur_rtde sampling the arm meanwhile:
    the samples (wall time, controller timestamp, joint 1) and each move's (start, end) wall times."""
    receive = rtde_receive.RTDEReceiveInterface(host)
    samples: list[tuple[float, float, float]] = []
    sampling = threading.Event()

    def sample() -> None:
        while not sampling.is_set():
            samples.append((time.time(), receive.getTimestamp(), receive.getActualQ()[0]))
            time.sleep(0.002)

    sampler = threading.Thread(target=sample)
    sampler.start()
    moving = []
    try:
        with ur3dq.robot.connect(host, heartbeat=False) as mover:
            q = mover.joints()
            for target in (q + [0.8, 0, 0, 0, 0, 0], q, q + [0.8, 0, 0, 0, 0, 0]):
                began = time.time()
                mover.movej(target, v=0.4, a=2.0)
                moving.append((began, time.time()))
    finally:
        sampling.set()
        sampler.join()
        receive.disconnect()
    return samples, moving


def controller_track(samples: list[tuple[float, float, float]]) -> np.ndarray:
    """Rows (time s, joint 1 rad) of the simulated arm on this machine's clock: each RTDE sample at the controller's
    own timestamp, shifted by the smallest receipt delay seen (a sampler held up by other threads reads a sample
    late; the controller's timestamp says when the arm was there)."""
    wall, stamp, angle = (np.array(column) for column in zip(*samples, strict=True))
    return np.column_stack([stamp + np.min(wall - stamp), angle])


def crossing_time(track: np.ndarray, value: float, move: tuple[float, float]) -> float | None:
    """When joint 1 passed `value` during `move` (start, end: one movej of joint 1 alone, monotonic)."""
    inside = track[(track[:, 0] >= move[0] - 0.1) & (track[:, 0] <= move[1] + 0.1)]
    times, angles = inside[:, 0], inside[:, 1]
    for i in range(1, len(angles)):
        a, b = angles[i - 1], angles[i]
        if a != b and min(a, b) <= value <= max(a, b):
            return float(times[i - 1] + (value - a) / (b - a) * (times[i] - times[i - 1]))
    return None


def live_view(browser: Browser, folder: Path) -> dict[str, Any]:
    """The live view's figures while the arm moves, with a 100-step program shown."""
    store = hundred_step_store(folder / "steps.json")
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    with powered_simulator(model="ur3", initial_q=list(START_Q)) as simulator, \
            served(simulator.host, store.path, folder / "serve-live.log") as server:
        url = server.url
        page.goto(url)
        page.wait_for_function("document.querySelectorAll('#steps li').length === 100 && "
                               "document.body.dataset.armDrawn === 'true'", timeout=20000)
        page.evaluate(WATCH_READOUT)
        frames_before = page.evaluate("window.ur3dqScreen.view.framesDrawn")
        samples, moving = moves_watched(simulator.host)
        frames = page.evaluate("window.ur3dqScreen.view.framesDrawn") - frames_before
        readouts = page.evaluate("window.readouts")
        deliveries = page.evaluate("window.ur3dqScreen.updateTimes")
    page.close()
    return live_view_figures(controller_track(samples), moving, readouts, deliveries, frames)


def live_view_figures(track: np.ndarray, moving: list[tuple[float, float]], readouts: list[list[Any]],
                      deliveries: list[list[float]], frames: int) -> dict[str, Any]:
    """Latency (each readout shown against when the arm passed its value), update and frame rates, and the states'
    server → page delays, from what `live_view` recorded."""
    latencies = []
    for shown_ms, text in readouts:
        shown = shown_ms / 1000.0
        move = next((m for m in moving if m[0] + 0.3 < shown < m[1]), None)
        passed = None if move is None else crossing_time(track, math.radians(float(text.split()[0])), move)
        if passed is not None:
            latencies.append(shown - passed)
    seconds_moving = sum(end - start for start, end in moving)
    updates = sum(1 for shown_ms, _ in readouts if any(start < shown_ms / 1000 < end for start, end in moving))
    delays = [got - read for read, got in deliveries if any(start < read / 1000 < end for start, end in moving)]
    if not latencies or not delays:
        raise SystemExit(f"the page showed no readout during the moves ({len(readouts)} readouts)")
    return {"latency_median_ms": round(1000 * float(np.median(latencies)), 1),
            "latency_p99_ms": round(1000 * float(np.percentile(latencies, 99)), 1),
            "latency_samples": len(latencies), "readout_updates_per_s": round(updates / seconds_moving, 1),
            "frames_drawn_per_s": round(frames / seconds_moving, 1), "steps_shown": 100,
            "server_to_page_median_ms": round(float(np.median(delays)), 1),
            "server_to_page_p99_ms": round(float(np.percentile(delays, 99)), 1)}


def report(figures: dict[str, Any]) -> None:
    """Each figure, with its goal and whether it is met."""
    for name, value in figures.items():
        goal = GOALS.get(name)
        if goal is None:
            print(f"  {name:28} {value!s:>8}")
            continue
        sign, bound = goal
        met = value <= bound if sign == "≤" else value >= bound
        print(f"  {name:28} {value:>8}   goal {sign} {bound:g}: {'met' if met else 'NOT met'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="page loads and live-view runs (default 3)")
    parser.add_argument("--json", type=Path, default=Path(__file__).resolve().parents[1] / "test-artifacts"
                        / "screen-timing.json", help="where the figures are written")
    arguments = parser.parse_args()
    if not os.access(CHROMIUM, os.X_OK):
        raise SystemExit(f"no Chromium at {CHROMIUM} (apt-get install chromium, or set UR3DQ_CHROMIUM)")
    loads, runs = [], []
    with tempfile.TemporaryDirectory() as temporary, sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            for _ in range(arguments.runs):
                loads.append((round(page_load(browser, Path(temporary)), 3), round(os.getloadavg()[0], 1)))
            for _ in range(arguments.runs):
                runs.append({**live_view(browser, Path(temporary)), "load_average_1min": round(os.getloadavg()[0], 1)})
        finally:
            browser.close()
    print(f"page load, {arguments.runs} runs (s, 1-min load average): {loads}")
    for index, figures in enumerate(runs):
        print(f"live view, run {index + 1}:")
        report(figures)
    summary = {"page_load_s": statistics.median(seconds for seconds, _ in loads),
               **{name: statistics.median(run[name] for run in runs) for name in GOALS if name != "page_load_s"}}
    print(f"medians of {arguments.runs} runs:")
    report(summary)
    arguments.json.parent.mkdir(parents=True, exist_ok=True)
    arguments.json.write_text(json.dumps({"page_loads": loads, "live_view_runs": runs, "medians": summary},
                                         indent=2))


if __name__ == "__main__":
    main()
