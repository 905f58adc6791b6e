"""The live view with a long program, in a real headless Chromium: the page lists all 100 steps of a stored program
and, while the simulated arm moves, its joint readout follows the arm through the move, never backwards, to where
the arm ends. (The screen's timing goals are measured by benchmarks/bench_screen.py, not here.)"""
import math
import socket

import numpy as np
import pytest

from polling import wait_for
from powered_simulator import powered_simulator
from robot_target import simulator_only
from screen_support import ARTIFACTS, START_Q, hundred_step_store, readout_radians, served

pytestmark = [pytest.mark.browser, simulator_only("the live view's test moves sim_ursim")]

# Every change of joint 1's readout, as the page showed it.
WATCH_READOUT = """() => { window.readouts = [];
  const readout = document.querySelector('[data-joint="0"]');
  new MutationObserver(() => window.readouts.push(readout.textContent))
    .observe(readout, {childList: true, characterData: true, subtree: true}); }"""
TURN = 0.6   # rad of joint 1, at 0.4 rad/s: about 1.5 s of motion


def shown_joint_1(page, radians: float) -> None:
    """Wait until the page's joint 1 readout shows `radians` (within its last digit)."""
    page.wait_for_function(f"Math.abs(parseFloat(document.querySelector('[data-joint=\"0\"]').textContent) - "
                           f"{math.degrees(radians)}) < 0.05", timeout=10000)


def test_the_readout_follows_a_moving_arm_with_a_hundred_step_program_shown(browser, tmp_path):
    import rtde_receive

    store = hundred_step_store(tmp_path / "poses.json")
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    with powered_simulator(initial_q=",".join(map(str, START_Q))) as simulator, \
            served(simulator.host, store.path, ARTIFACTS / "screen-live-view-server.log") as server:
        page.goto(server.url)
        page.wait_for_function("document.querySelectorAll('#steps li').length === 100 && "
                               "document.body.dataset.armDrawn === 'true'", timeout=20000)
        # the server's own connection and warm-up first: a program it starts would end the one that moves the arm
        assert wait_for(lambda: "; ready" in server.log_text(), timeout=30), server.log_text()
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        try:
            start = np.array(receive.getActualQ())
            shown_joint_1(page, start[0])
            page.evaluate(WATCH_READOUT)
            target = start + [TURN, 0, 0, 0, 0, 0]
            with socket.create_connection((simulator.host, 30002), timeout=5) as secondary:   # as any client moves it
                secondary.sendall(f"movej({target.tolist()}, a=2.0, v=0.4)\n".encode())
            assert wait_for(lambda: np.max(np.abs(np.array(receive.getActualQ()) - target)) < 1e-4
                            and np.max(np.abs(receive.getActualQd())) < 1e-9, timeout=20)
            end = np.array(receive.getActualQ())
        finally:
            receive.disconnect()
        shown_joint_1(page, end[0])
        shown = [readout_radians(text) for text in page.evaluate("window.readouts")]
    page.close()
    assert abs(end[0] - start[0] - TURN) < 1e-3
    passing = [value for value in shown if start[0] + 0.01 < value < end[0] - 0.01]
    assert len(passing) >= 5, shown   # shown on the way, not only at the end
    assert all(b >= a - 1e-4 for a, b in zip(shown, shown[1:])), shown   # never an older state after a newer one
    assert min(shown) >= start[0] - 1e-3 and abs(shown[-1] - end[0]) < 1e-3
