"""What the page says about the arm, in a real headless Chromium against sim_ursim (a page in ° and mm): a jog's
speed at the same precision as the jog speed's label, and a protective stop's refusal pointing at the page's Unlock
button, not at the command line (whose own message is unchanged)."""
import re

import pytest

from robot_target import simulator_only
from screen_support import ARTIFACTS, button, expect, hold, page_on_powered_arm

pytestmark = [pytest.mark.browser, simulator_only("the messages test protective-stops sim_ursim")]

NOTICE = "document.getElementById('notice').textContent"
SPEED = r"(-?\d+(?:\.\d+)?) °/s"


def test_a_jogs_speed_reads_as_its_label_and_a_protective_stop_points_at_unlock(browser, tmp_path):
    from sim_ursim.control_channel import send_request

    with page_on_powered_arm(browser, tmp_path / "poses.json", ARTIFACTS / "screen-robot-messages.log") as \
            (page, simulator, _):
        label = page.locator("#jog-speed-value").text_content()
        hold(page, "J1+", 0.3)
        page.wait_for_function(f"{NOTICE}.startsWith('jog J1+')", timeout=10000)
        jog = page.locator("#notice").text_content()

        assert send_request(simulator.host, "protective-stop", reason="test")["ok"]
        expect(page.locator("#safety-mode")).to_have_text("PROTECTIVE_STOP", timeout=10000)
        expect(button(page, "Unlock")).to_be_enabled()
        hold(page, "J1+", 0.3)
        page.wait_for_function(f"{NOTICE}.startsWith('Error')", timeout=10000)
        refusal = page.locator("#notice").text_content()
    assert "protective stop" in refusal and "(press Unlock)" in refusal, refusal
    assert "ur3dq robot unlock" not in refusal and "unlock_protective_stop" not in refusal, refusal
    top = float(re.search(r"of " + SPEED, label).group(1))
    shown = re.search(r"jog J1\+: " + SPEED, jog).group(1)
    assert shown == f"{0.2 * top:.2f}".rstrip("0").rstrip("."), (label, jog)   # 20 % of the label, same digits
    from ur3dq.errors import UNLOCK_HINT

    assert "`ur3dq robot unlock`" in UNLOCK_HINT   # what the command line still says
