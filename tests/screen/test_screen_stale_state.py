"""A frozen state stream, in a real headless Chromium: while the simulator sends nothing, the page greys its readouts
out and says "no data for X s" within a second, claims no robot or program mode (never "PLAYING" from a frozen
stream), and shows the live state again once the stream comes back."""
import socket
import time

import pytest

from robot_target import simulator_only
from screen_support import ARTIFACTS, START_Q, page_on_powered_arm

pytestmark = [pytest.mark.browser, simulator_only("the stale-state test freezes sim_ursim's streams")]

FREEZE_S = 3.0
SHOWN_STALE_WITHIN_S = 1.0   # the server marks data older than 0.3 s; the rest is the page's next update
ROBOT_LINE = "document.getElementById('robot-line').textContent"
STALE = f"document.body.classList.contains('stale') && {ROBOT_LINE}.includes('no data for')"


def test_a_frozen_stream_is_shown_stale_within_a_second_and_live_after_the_thaw(browser, tmp_path):
    from sim_ursim.control_channel import send_request

    with page_on_powered_arm(browser, tmp_path / "poses.json", ARTIFACTS / "screen-stale-server.log") as \
            (page, simulator, _):
        with socket.create_connection((simulator.host, 30002), timeout=5) as secondary:   # a slow program plays
            target = [START_Q[0] + 1.0, *START_Q[1:]]
            secondary.sendall(f"movej({target}, a=1.0, v=0.05)\n".encode())
        page.wait_for_function(f"{ROBOT_LINE}.includes('program PLAYING')", timeout=10000)
        assert not page.evaluate(STALE)

        reply = send_request(simulator.host, "freeze", seconds=FREEZE_S)
        frozen_at = time.monotonic()
        assert reply["ok"], reply
        page.wait_for_function(STALE, timeout=FREEZE_S * 1000)
        shown_after = time.monotonic() - frozen_at
        line = page.locator("#robot-line").text_content()
        program = page.locator("#program-state").text_content()
        readout_style = page.locator('[data-joint="0"]').evaluate("element => getComputedStyle(element).fontStyle")
        stale_during_freeze = time.monotonic() - frozen_at < FREEZE_S

        page.wait_for_function(f"!document.body.classList.contains('stale') && {ROBOT_LINE}.includes('RUNNING')",
                               timeout=15000)
        page.screenshot(path=str(ARTIFACTS / "screen-stale-after-thaw.png"))
    assert stale_during_freeze
    assert shown_after < SHOWN_STALE_WITHIN_S, shown_after
    assert "PLAYING" not in line and "RUNNING" not in line, line
    assert program == "UNKNOWN", program
    assert readout_style == "italic"
