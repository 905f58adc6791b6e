"""The cell's screen end to end, in a real headless Chromium against `ur3dq serve` and a simulator process: the
contract the outside checks rely on, then the job a technician does on it, in order (each test continues the last).

Screenshots of the jog panel, the running program and a failing check (1280×800 and 800×1280) are saved among the
test artifacts (test-artifacts/ or $UR3DQ_TEST_ARTIFACTS).
"""
import json
import subprocess
import time
import urllib.request

import numpy as np
import pytest

from polling import wait_for
from robot_target import simulator_only
from screen_support import (
    ARTIFACTS,
    START_Q,
    button,
    environment,
    expect,
    hold,
    insert_gripper_and_wait,
    notice_after,
    readout_radians,
    screenshots,
    served,
    set_speed_slider,
    ur3dq_command,
)
from ur3dq.store import PoseStore

# Exclusive: the contract holds times (a release stops the arm within 0.02 rad, a closed page within 0.3 s, a killed
# server within 0.5 s, a CLI edit shows within 1 s) that a CPU shared with the parallel pass's other tests would
# measure instead.
pytestmark = [pytest.mark.browser, pytest.mark.exclusive,
              simulator_only("the screen's end-to-end tests drive sim_ursim")]

CONTRACT_BUTTONS = ["Power on", "Power off", "Brake release", "Unlock", "Freedrive", "Record pose", "Check", "Run",
                    "Pause", "Resume", "Stop", "Move here", "Undo", "Redo"] + [
    f"{axis}{sign}" for axis in ("J1", "J2", "J3", "J4", "J5", "J6", "X", "Y", "Z", "RX", "RY", "RZ")
    for sign in "+-"]
TABLE = {"name": "table", "min": [-0.6, -0.45, -0.02], "max": [-0.15, 0.2, 0.08]}
# The aria-current step names in the order they were set, from the page itself (none is missed between polls).
WATCH_CURRENT = """() => { window.seenSteps = [];
  new MutationObserver(() => {
    const row = document.querySelector('#steps [aria-current="step"]'), seen = window.seenSteps;
    if (row && seen[seen.length - 1] !== row.dataset.step) seen.push(row.dataset.step);
  }).observe(document.getElementById('steps'),
             {subtree: true, attributes: true, attributeFilter: ['aria-current']}); }"""


class Cell:
    """The module's simulator, store, server, browser page and an RTDE reader of the simulated arm."""

    def __init__(self, simulator, store, server, page, receive):
        self.simulator, self.store, self.server, self.page, self.receive = simulator, store, server, page, receive

    def q(self) -> np.ndarray:
        return np.array(self.receive.getActualQ())

    def at_rest(self) -> bool:
        return float(np.max(np.abs(self.receive.getActualQd()))) < 1e-3

    def cli(self, *arguments: str) -> subprocess.CompletedProcess:
        return subprocess.run(ur3dq_command(*arguments, store=self.store), capture_output=True, text=True,
                              timeout=60, env=environment(self.store.parent / "state"), check=True)


@pytest.fixture(scope="module")
def cell(browser, tmp_path_factory):
    import rtde_receive

    from sim_ursim.launch import simulator_process

    folder = tmp_path_factory.mktemp("screen")
    cell_file = folder / "cell.json"
    cell_file.write_text(json.dumps({"floor": {"z": -0.02}, "boxes": [TABLE], "margin": 0.01}))
    store = folder / "poses.json"
    with simulator_process(model="ur3", initial_q=list(START_Q)) as simulator, \
            served(simulator.host, store, ARTIFACTS / "screen-server.log", "--cell", str(cell_file)) as server:
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        errors = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(server.url)
        try:
            yield Cell(simulator, store, server, page, receive)
        finally:
            receive.disconnect()
            page.close()
        assert errors == [], errors


def settled(page) -> None:
    """Wait until a page has drawn the arm, and half a second more (a page still compiling its first frame sends
    no heartbeat meanwhile, and a jog needs one every 250 ms)."""
    page.wait_for_function("document.body.dataset.armDrawn === 'true'", timeout=20000)
    page.wait_for_timeout(500)


def test_the_page_keeps_its_contract(cell):
    page = cell.page
    for name in CONTRACT_BUTTONS:
        expect(button(page, name)).to_have_count(1)
    for index in range(6):
        expect(page.locator(f'[data-joint="{index}"]')).to_have_count(1)
    expect(page.locator("canvas")).to_have_count(1)
    page.wait_for_function("document.body.dataset.armDrawn === 'true'", timeout=20000)
    with urllib.request.urlopen(cell.server.url + "healthz", timeout=5) as answer:
        health = json.loads(answer.read())
    assert answer.status == 200 and set(health) == {"robot", "program"}
    assert health == {"robot": "POWER_OFF", "program": "STOPPED"}


def test_power_on_and_brake_release(cell):
    page = cell.page
    expect(button(page, "Power on")).to_be_enabled(timeout=20000)
    button(page, "Power on").click()
    expect(button(page, "Brake release")).to_be_enabled(timeout=20000)
    button(page, "Brake release").click()
    expect(page.locator("#robot-mode")).to_have_text("RUNNING", timeout=20000)
    assert json.loads(urllib.request.urlopen(cell.server.url + "healthz").read())["robot"] == "RUNNING"


def test_a_held_jog_moves_joint_1_and_release_stops_it(cell):
    page = cell.page
    expect(button(page, "J1+")).to_be_enabled(timeout=10000)
    before = cell.q()
    button(page, "J1+").hover()
    page.mouse.down()
    time.sleep(0.5)
    page.mouse.up()
    released = cell.q()
    assert wait_for(cell.at_rest, timeout=2.0)
    after = cell.q()
    assert released[0] - before[0] > 0.01, "J1+ held for 0.5 s did not move joint 1"
    assert np.allclose(after[1:], before[1:], atol=1e-6)
    assert after[0] - released[0] <= 0.02, f"joint 1 went {after[0] - released[0]:.4f} rad after the release"
    tapped = cell.q()
    button(page, "J1+").click()                     # pressed and released at once: no jog runs on
    time.sleep(0.6)
    assert wait_for(cell.at_rest, timeout=2.0) and abs(cell.q()[0] - tapped[0]) < 0.01
    after = cell.q()
    page.wait_for_function(f"Math.abs(parseFloat(document.querySelector('[data-joint=\"0\"]').textContent) - "
                           f"{np.degrees(after[0])}) < 0.05", timeout=2000)
    shown = readout_radians(page.locator('[data-joint="0"]').text_content())
    assert abs(shown - cell.q()[0]) <= 1e-3
    screenshots(page, "jog-panel", showing="#teach")


def test_record_three_poses_then_add_an_output_and_a_wait(cell):
    page = cell.page
    for index, jog in enumerate(("J2+", "J1-", "J3-")):
        button(page, "Record pose").click()
        name = page.locator("#ask input[name=name]")
        expect(name).to_have_value(f"pose-{index + 1}")
        button(page, "OK").click()
        expect(page.locator(f'[data-step="pose-{index + 1}"]')).to_have_count(1)
        if index < 2:
            hold(page, jog, 0.4)
            assert wait_for(cell.at_rest, timeout=2.0)
    insert_gripper_and_wait(page, "pose-3", "300ms")
    steps = PoseStore(cell.store).load_program()
    assert [step.name for step in steps] == ["pose-1", "pose-2", "pose-3", "output-1", "wait-1"]
    assert steps[3].output == "tool" and steps[4].seconds == pytest.approx(0.3)
    button(page, "Undo").click()
    page.wait_for_selector('[data-step="wait-1"]', state="detached", timeout=3000)
    button(page, "Redo").click()
    page.wait_for_selector('[data-step="wait-1"]', timeout=3000)


def test_check_passes(cell):
    page = cell.page
    button(page, "Check").click()
    expect(page.locator("#check-summary")).to_have_class("ok", timeout=10000)
    for name in ("pose-1", "pose-2", "pose-3"):
        expect(page.locator(f'[data-step="{name}"]')).to_have_class("ok")


def test_run_follows_the_program_and_ends_at_the_last_pose(cell):
    page = cell.page
    set_speed_slider(page, 40)
    page.evaluate(WATCH_CURRENT)
    button(page, "Run").click()
    expect(page.locator("#ask")).to_contain_text("Run 5 steps ('pose-1' to 'wait-1') on the arm?")
    page.evaluate("document.getElementById('notice').textContent = ''")
    button(page, "Yes").click()
    page.wait_for_function("(window.seenSteps || []).includes('pose-2')", timeout=10000)
    screenshots(page, "running-program", showing="#run")
    page.wait_for_function("document.getElementById('notice').textContent.startsWith('Ran')", timeout=30000)
    seen = page.evaluate("window.seenSteps")
    order = ["pose-1", "pose-2", "pose-3", "output-1", "wait-1"]
    assert [order.index(name) for name in seen] == sorted(order.index(name) for name in seen), seen
    assert {"pose-1", "pose-2", "pose-3", "wait-1"} <= set(seen)
    last = PoseStore(cell.store).get("pose-3")
    tcp = np.array(cell.receive.getActualTCPPose())
    assert np.linalg.norm(tcp[:3] - np.array(last.ur_pose[:3])) <= 0.0005
    expect(page.locator('#steps [aria-current="step"]')).to_have_count(0)


def test_pause_mid_move_stops_the_arm_and_resume_finishes(cell):
    page = cell.page
    set_speed_slider(page, 50)
    page.evaluate(WATCH_CURRENT)
    button(page, "Run").click()
    button(page, "Yes").click()
    assert wait_for(lambda: float(np.max(np.abs(cell.receive.getActualQd()))) > 0.01, timeout=10)
    button(page, "Pause").click()
    expect(page.locator("#program-state")).to_have_text("PAUSED", timeout=5000)
    assert wait_for(cell.at_rest, timeout=1.5), "the arm did not stop on Pause"
    paused_at = cell.q()
    time.sleep(1.0)
    assert np.allclose(cell.q(), paused_at, atol=1e-6), "the arm moved while paused"
    notice = notice_after(page, lambda: button(page, "Resume").click(), "Ran", timeout=60)
    assert notice.startswith("Ran 5 steps"), notice
    last = PoseStore(cell.store).get("pose-3")
    assert np.linalg.norm(np.array(cell.receive.getActualTCPPose())[:3] - np.array(last.ur_pose[:3])) <= 0.0005
    set_speed_slider(page, 100)


def test_run_from_the_selected_step_loops_and_stop(cell):
    page = cell.page
    page.locator('[data-step="pose-2"]').click()
    page.locator("#from-selected").check()
    page.locator("#loops").fill("2")
    button(page, "Run").click()
    expect(page.locator("#ask")).to_contain_text("Run 4 steps ('pose-2' to 'wait-1') on the arm 2 times?")
    assert notice_after(page, lambda: button(page, "No").click(), "answered no") == "answered no: nothing done."
    page.locator("#from-selected").uncheck()
    page.locator("#loops").fill("1")
    set_speed_slider(page, 20)
    button(page, "Run").click()
    button(page, "Yes").click()
    assert wait_for(lambda: float(np.max(np.abs(cell.receive.getActualQd()))) > 0.01, timeout=10)
    notice = notice_after(page, lambda: button(page, "Stop").click(), "Error", server=cell.server)
    assert "stopped by the operator" in notice, notice
    assert wait_for(cell.at_rest, timeout=1.0)
    expect(page.locator("#program-state")).to_have_text("STOPPED", timeout=3000)
    set_speed_slider(page, 100)


def test_freedrive_on_and_off(cell):
    page = cell.page
    freedrive = button(page, "Freedrive")
    freedrive.click()
    expect(freedrive).to_have_attribute("aria-pressed", "true", timeout=5000)
    expect(button(page, "J1+")).to_be_disabled()
    freedrive.click()
    expect(freedrive).to_have_attribute("aria-pressed", "false", timeout=5000)
    expect(button(page, "J1+")).to_be_enabled(timeout=5000)


def test_an_edit_made_on_the_command_line_shows_within_a_second(cell):
    cell.cli("poses", "add-step", "--after", "pose-2", "message", "hello from the shell")
    shown_by = time.monotonic() + 1.0
    cell.page.wait_for_selector('[data-step="message-1"]', timeout=3000)
    assert time.monotonic() <= shown_by
    expect(cell.page.locator('[data-step="message-1"]')).to_contain_text("hello from the shell")
    cell.cli("poses", "rm", "message-1", "--yes")
    cell.page.wait_for_selector('[data-step="message-1"]', state="detached", timeout=3000)


def test_speeds_and_readouts_are_in_the_units_chosen(cell):
    page = cell.page
    page.locator('[data-step="pose-2"]').click()
    page.locator("#edit-move").select_option("linear")
    page.locator("#edit-speed").fill("100")
    button(page, "Apply").click()
    expect(page.locator('[data-step="pose-2"] .speed')).to_have_text("100 mm/s", timeout=3000)
    assert PoseStore(cell.store).get_step("pose-2").motion.speed == pytest.approx(0.1)
    page.locator("#unit-length").select_option("m")
    page.locator("#unit-angle").select_option("rad")
    expect(page.locator('[data-step="pose-2"] .speed')).to_have_text("0.1 m/s", timeout=3000)
    expect(page.locator('[data-joint="0"]')).to_contain_text("rad", timeout=3000)
    assert abs(readout_radians(page.locator('[data-joint="0"]').text_content()) - cell.q()[0]) <= 1e-3
    page.locator("#unit-length").select_option("mm")
    page.locator("#unit-angle").select_option("deg")
    expect(page.locator('[data-joint="0"]')).to_contain_text("°", timeout=3000)
    button(page, "Undo").click()
    expect(page.locator('[data-step="pose-2"] .move')).to_have_text("joint", timeout=3000)


def test_outputs_switch_and_move_here_goes_to_the_waypoint(cell):
    page = cell.page
    output = button(page, "DO 3")
    output.click()
    assert wait_for(lambda: cell.receive.getActualDigitalOutputBits() & (1 << 3), timeout=2.0)
    expect(output).to_have_attribute("aria-pressed", "true", timeout=2000)
    output.click()
    assert wait_for(lambda: not cell.receive.getActualDigitalOutputBits() & (1 << 3), timeout=2.0)
    page.locator('[data-step="pose-1"]').click()
    button(page, "Move here").click()
    expect(page.locator("#ask")).to_contain_text("Move the arm to 'pose-1'")
    notice = notice_after(page, lambda: button(page, "Yes").click(), "Moved")
    assert notice.startswith("Moved to 'pose-1'"), notice
    assert np.allclose(cell.q(), PoseStore(cell.store).get("pose-1").joints, atol=2e-3)


def test_a_failing_check_is_shown_in_red(cell):
    page = cell.page
    height = PoseStore(cell.store).get("pose-3").ur_pose[2]
    cell.cli("poses", "offset", "into-table", "--from", "pose-3", "--z", f"{0.03 - height:.4f}", "--frame", "base",
             "--after", "pose-3")
    page.wait_for_selector('[data-step="into-table"]', timeout=3000)
    button(page, "Check").click()
    expect(page.locator("#check-summary")).to_have_class("fail", timeout=10000)
    expect(page.locator('[data-step="into-table"]')).to_have_class("fail")
    expect(page.locator("#problems")).to_contain_text("into-table")
    expect(page.locator("#problems")).to_contain_text('keep-out box "table"')
    screenshots(page, "failing-check", showing="#run")
    page.locator('[data-step="into-table"]').click()
    button(page, "Run").click()
    expect(page.locator("#notice")).to_contain_text("path check", timeout=10000)
    cell.cli("poses", "rm", "into-table", "--yes")
    page.wait_for_selector('[data-step="into-table"]', state="detached", timeout=3000)
    page.locator('[data-step="pose-1"]').click()


def test_a_second_page_is_read_only_until_it_takes_control(cell, browser):
    first = cell.page
    second = browser.new_page(viewport={"width": 800, "height": 1280})
    second.goto(cell.server.url)
    expect(second.locator("#control-line")).to_contain_text("Read-only", timeout=10000)
    for name in ("J1+", "Run", "Power off", "Record pose"):
        expect(button(second, name)).to_be_disabled()
    button(second, "Take control").click()
    expect(second.locator("#control-line")).to_have_text("You have control.", timeout=5000)
    settled(second)
    expect(button(second, "J1+")).to_be_enabled(timeout=5000)
    expect(first.locator("#control-line")).to_contain_text("Read-only", timeout=5000)
    expect(button(first, "J1+")).to_be_disabled()
    before = cell.q()
    hold(second, "J1-", 0.5)
    assert wait_for(cell.at_rest, timeout=2.0) and cell.q()[0] < before[0] - 0.01
    second.close()
    expect(first.locator("#control-line")).to_contain_text("Nobody has control", timeout=5000)
    button(first, "Take control").click()
    expect(first.locator("#control-line")).to_have_text("You have control.", timeout=5000)


def test_closing_the_page_during_a_held_jog_stops_the_arm(cell, browser):
    page = browser.new_page()
    page.goto(cell.server.url)
    button(page, "Take control").click()
    expect(button(page, "J1+")).to_be_enabled(timeout=10000)
    settled(page)
    button(page, "J1+").hover()
    page.mouse.down()
    assert wait_for(lambda: float(cell.receive.getActualQd()[0]) > 0.05, timeout=3.0)
    time.sleep(0.2)
    closed = time.monotonic()
    page.close()
    assert wait_for(cell.at_rest, timeout=2.0, interval=0.002)
    stopped_after = time.monotonic() - closed
    assert stopped_after <= 0.3, f"the arm moved on for {stopped_after:.3f} s after the page closed"
    button(cell.page, "Take control").click()
    expect(cell.page.locator("#control-line")).to_have_text("You have control.", timeout=5000)


def test_killing_the_server_during_a_run_stops_the_arm(cell):
    page = cell.page
    set_speed_slider(page, 20)
    button(page, "Run").click()
    button(page, "Yes").click()
    assert wait_for(lambda: float(np.max(np.abs(cell.receive.getActualQd()))) > 0.01, timeout=10)
    killed = time.monotonic()
    cell.server.process.kill()
    assert wait_for(lambda: cell.at_rest() and cell.receive.getRuntimeState() != 2, timeout=2.0, interval=0.002)
    assert time.monotonic() - killed <= 0.5, "the controller's watchdog did not stop the run of a killed server"
    expect(page.locator("#robot-line")).to_contain_text("disconnected", timeout=5000)
