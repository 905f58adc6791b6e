"""The 3D view's name labels in a real headless Chromium: poses taught a few millimetres apart (an approach above a
pick, a place beside it) keep every name readable: no two labels cover each other, the problem labels of a failed
check included."""
import json

import numpy as np
import pytest

from screen_support import ARTIFACTS, screenshots, served
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

pytestmark = [pytest.mark.browser]

UR3 = robot_model("ur3")
Q = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
# Joint 1 turned 1, 2 and 3 mrad: TCPs 0.3–1 mm apart, far closer than a label's height at any zoom.
NAMES = ("pick", "pick-approach", "place", "place-retract")
LABEL_BOXES = """() => [...document.querySelectorAll('.pose-label')]
  .filter((label) => label.offsetParent !== null)
  .map((label) => { const box = label.getBoundingClientRect();
                    return {text: label.textContent, left: box.left, right: box.right, top: box.top,
                            bottom: box.bottom}; })"""


def overlapping(boxes):
    return [(a["text"], b["text"]) for index, a in enumerate(boxes) for b in boxes[index + 1:]
            if a["left"] < b["right"] and b["left"] < a["right"] and a["top"] < b["bottom"] and b["top"] < a["bottom"]]


def test_names_of_poses_taught_close_together_do_not_cover_each_other(browser, tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    for index, name in enumerate(NAMES):
        q = Q + np.array([1e-3 * index, 0, 0, 0, 0, 0])
        store.add(Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=tuple(q)))
    with served(None, store.path, ARTIFACTS / "screen-labels.log") as server:
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        try:
            page.goto(server.url)
            page.wait_for_function(f"document.querySelectorAll('.pose-label').length >= {len(NAMES)}",
                                   timeout=20000)
            page.wait_for_timeout(300)
            boxes = page.evaluate(LABEL_BOXES)
            screenshots(page, "labels-close-together", showing="#view")
        finally:
            page.close()
    assert sorted(box["text"] for box in boxes) == sorted(NAMES), json.dumps(boxes)
    assert not overlapping(boxes), json.dumps(boxes)
