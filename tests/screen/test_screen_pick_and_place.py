"""The pick-and-place job on the page alone: after `ur3dq serve` (an empty store, a cell file with a table box) every
step is a click in a real headless Chromium — power on, brake release, four poses taught by jog and by freedrive
(the simulator's control channel stands in for the operator's hand), the approach and retract made linear, a gripper
output and a wait inserted, Check, Run, Pause, Resume — and the arm ends at the last pose."""
import json
import time

import numpy as np
import pytest

from polling import wait_for
from robot_target import simulator_only
from screen_support import (
    ARTIFACTS,
    START_Q,
    button,
    expect,
    hold,
    insert_gripper_and_wait,
    notice_after,
    served,
    set_speed_slider,
)
from ur3dq.store import PoseStore

# Exclusive: a jog held for a fixed time and a pause in mid-move, timed on a CPU of their own.
pytestmark = [pytest.mark.browser, pytest.mark.exclusive, simulator_only("the operator's hand in freedrive")]

TABLE = {"name": "table", "min": [-0.6, -0.45, -0.02], "max": [-0.15, 0.2, 0.08]}
PLACE_SHIFT = np.array([0.5, 0.1, -0.1, 0.0, 0.0, 0.0])   # where the operator pushes the arm in freedrive (rad)
PROGRAM = ["pose-1", "pose-2", "output-1", "wait-1", "pose-3", "pose-4"]


def record(page, name: str) -> None:
    """Record pose with the offered name (the next free one)."""
    button(page, "Record pose").click()
    expect(page.locator("#ask input[name=name]")).to_have_value(name)
    button(page, "OK").click()
    expect(page.locator(f'[data-step="{name}"]')).to_have_count(1)


def jog_and_record(page, receive, jog: str, name: str) -> None:
    """Hold a jog button, wait for the arm to rest, record the pose as `name`."""
    hold(page, jog, 0.6)
    assert wait_for(lambda: float(np.max(np.abs(receive.getActualQd()))) < 1e-3, timeout=3.0)
    record(page, name)


def push_by_hand_and_record(page, host: str, receive, q: np.ndarray, name: str) -> None:
    """Freedrive on (the page), the operator's hand moves the arm to `q`, Record pose, freedrive off (the page)."""
    from sim_ursim.control_channel import send_request

    freedrive = button(page, "Freedrive")
    freedrive.click()
    expect(freedrive).to_have_attribute("aria-pressed", "true", timeout=5000)
    assert send_request(host, "move-by-hand", q=[float(v) for v in q]).get("ok")
    assert wait_for(lambda: np.allclose(receive.getActualQ(), q, atol=1e-6), timeout=3.0)
    record(page, name)
    freedrive.click()
    expect(freedrive).to_have_attribute("aria-pressed", "false", timeout=5000)


def make_linear(page, name: str) -> None:
    page.locator(f'[data-step="{name}"]').click()
    page.locator("#edit-move").select_option("linear")
    button(page, "Apply").click()
    expect(page.locator(f'[data-step="{name}"] .move')).to_have_text("linear", timeout=3000)


def test_the_pick_and_place_job_on_the_page_alone(browser, tmp_path):
    import rtde_receive

    from sim_ursim.launch import simulator_process

    cell_file = tmp_path / "cell.json"
    cell_file.write_text(json.dumps({"floor": {"z": -0.02}, "boxes": [TABLE], "margin": 0.01}))
    store = tmp_path / "poses.json"
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    with simulator_process(model="ur3", initial_q=list(START_Q)) as simulator, \
            served(simulator.host, store, ARTIFACTS / "screen-pick-and-place.log", "--cell", str(cell_file)) as server:
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        try:
            page.goto(server.url)
            for name in ("Power on", "Brake release"):
                expect(button(page, name)).to_be_enabled(timeout=20000)
                button(page, name).click()
            expect(page.locator("#robot-mode")).to_have_text("RUNNING", timeout=20000)
            page.locator("#jog-speed").fill("100")
            jog_and_record(page, receive, "J1-", "pose-1")    # above the part
            jog_and_record(page, receive, "Z-", "pose-2")     # down to it
            jog_and_record(page, receive, "Z+", "pose-3")     # back up
            push_by_hand_and_record(page, simulator.host, receive, np.array(receive.getActualQ()) + PLACE_SHIFT,
                                    "pose-4")
            make_linear(page, "pose-2")
            make_linear(page, "pose-3")
            insert_gripper_and_wait(page, "pose-2", "0.3")
            assert [step.name for step in PoseStore(store).load_program()] == PROGRAM
            button(page, "Check").click()
            expect(page.locator("#check-summary")).to_have_class("ok", timeout=10000)
            run_pause_and_resume(page, receive)
            last = PoseStore(store).get("pose-4")
            assert np.linalg.norm(np.array(receive.getActualTCPPose())[:3] - np.array(last.ur_pose[:3])) <= 0.0005
            assert receive.getActualDigitalOutputBits() & (1 << 16), "the gripper's tool output 0 is not on"
        finally:
            receive.disconnect()
            page.close()
    assert errors == [], errors


def run_pause_and_resume(page, receive) -> None:
    """Run (answer yes), Pause in the first move, check the arm rests, Resume until the page says it ran."""
    set_speed_slider(page, 60)
    button(page, "Run").click()
    expect(page.locator("#ask")).to_contain_text("Run 6 steps ('pose-1' to 'pose-4') on the arm?")
    button(page, "Yes").click()
    assert wait_for(lambda: float(np.max(np.abs(receive.getActualQd()))) > 0.01, timeout=10)
    button(page, "Pause").click()
    expect(page.locator("#program-state")).to_have_text("PAUSED", timeout=5000)
    assert wait_for(lambda: float(np.max(np.abs(receive.getActualQd()))) < 1e-3, timeout=1.5)
    paused_at = np.array(receive.getActualQ())
    time.sleep(0.3)
    assert np.allclose(receive.getActualQ(), paused_at, atol=1e-6), "the arm moved while paused"
    notice = notice_after(page, lambda: button(page, "Resume").click(), "Ran", timeout=60)
    assert notice.startswith("Ran 6 steps"), notice
