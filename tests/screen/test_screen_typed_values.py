"""Values typed on the page, in a real headless Chromium (a page in ° and mm, no robot): a refused speed, blend or
wait names the value as it was typed, in the page's units (never its SI value), and what the list shows of an
accepted one has the units layer's one display precision."""
import math

import numpy as np
import pytest

from screen_support import ARTIFACTS, START_Q, button, expect, notice_after, served
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

pytestmark = [pytest.mark.browser]

UR3 = robot_model("ur3")
REFUSED = [   # (move, speed, blend, the notice)
    ("joint", "-5", "", "Error: speed must be more than 0 °/s, got -5 °/s"),
    ("joint", "", "-5", "Error: blend must be from 0 mm to 1000 mm, got -5 mm"),
    ("joint", "", "1e300", "Error: blend must be from 0 mm to 1000 mm, got 1e300 mm"),
    ("linear", "-0.5m/s", "", "Error: speed must be more than 0 mm/s, got -0.5m/s"),
    ("joint", "1e-9", "", "Error: waypoint 'p': speed 1e-09 °/s is outside the ur3's range for a joint move, "
                          "0.06 °/s to 180 °/s"),
]


def set_motion(page, move: str, speed: str, blend: str) -> None:
    page.locator("#edit-move").select_option(move)
    page.locator("#edit-speed").fill(speed)
    page.locator("#edit-blend").fill(blend)
    button(page, "Apply").click()


def test_refused_values_are_named_as_typed_and_accepted_ones_shown_at_one_precision(browser, tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(Pose.from_dual_quaternion("p", UR3.fk(np.array(START_Q)), "ur3", joints=START_Q))
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    with served(None, store.path, ARTIFACTS / "screen-typed-values.log") as server:
        page.goto(server.url)
        expect(page.locator("#control-line")).to_have_text("You have control.")   # the first page has it
        page.locator('[data-step="p"]').click()
        expect(page.locator("#motion-editor")).to_be_visible()
        notices = [notice_after(page, lambda typed=typed: set_motion(page, *typed), "Error")
                   for *typed, _ in REFUSED]

        notice_after(page, lambda: set_motion(page, "joint", str(math.degrees(1.05)), "12.345"), "set")
        row = page.locator('[data-step="p"]')
        speed_shown, details = row.locator(".speed").text_content(), row.locator(".details").text_content()
        button(page, "Add wait").click()
        page.locator("#ask input[name=seconds]").fill("1e-300")
        wait_refusal = notice_after(page, lambda: button(page, "OK").click(), "Error")
    page.close()
    assert notices == [notice for *_, notice in REFUSED]
    assert speed_shown == "60.16 °/s" and details == "blend 12.3 mm", (speed_shown, details)
    assert wait_refusal == ("Error: step 'wait-1' (wait): a wait lasts at least 0.002 s (one control cycle), got "
                            "1e-300 s")
