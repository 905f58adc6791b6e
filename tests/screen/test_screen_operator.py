"""The screen as an operator uses it on a 1024×768 touch panel, in a real headless Chromium against `ur3dq serve` and a
simulator process, with a 100-step program: controls big enough for a finger, a keyboard jog that ends however the
key or the focus leaves its button, Stop in view through a whole run, the motion editor keeping what is typed, Enter
in the dialogs, and the step list from the keyboard (each test continues the last)."""
import numpy as np
import pytest

from polling import wait_for
from robot_target import simulator_only
from screen_support import (
    ARTIFACTS,
    button,
    environment,
    expect,
    hundred_step_store,
    served,
    set_speed_slider,
    ur3dq_command,
)
from ur3dq.store import PoseStore

# Exclusive: a jog must stop within a fixed time after its key comes up, on a CPU of its own.
pytestmark = [pytest.mark.browser, pytest.mark.exclusive, simulator_only("the screen's jog and run")]

SIZE = {"width": 1024, "height": 768}
FINGER = 44   # px: the smallest control a finger hits reliably
J1_MINUS = 'button[data-axis="J1"][data-direction="-1"]'
# Every interactive control the page shows, with its box (a checkbox is hit through its label).
CONTROL_BOXES = """() => [...document.querySelectorAll('button, select, input, #steps li')]
  .filter((element) => element.offsetParent !== null && !element.closest('dialog'))
  .map((element) => { const target = element.type === 'checkbox' ? element.closest('label') : element;
                      const box = target.getBoundingClientRect();
                      return {what: element.id || element.dataset.io || element.dataset.axis + element.dataset.direction
                                    || element.dataset.step || element.tagName,
                              width: box.width, height: box.height}; })"""
# Each frame while it runs: Stop's box, the header's height, the panels' scroll, the running step and whether the
# step list shows it.
WATCH_STOP = """() => { window.stopBoxes = [];
  const look = () => {
    const stop = document.getElementById('stop').getBoundingClientRect();
    const row = document.querySelector('#steps [aria-current="step"]');
    const list = document.getElementById('steps').getBoundingClientRect(), at = row && row.getBoundingClientRect();
    window.stopBoxes.push({top: stop.top, bottom: stop.bottom, left: stop.left, right: stop.right,
                           header: document.querySelector('header').getBoundingClientRect().height,
                           panels: document.getElementById('panels').scrollTop, step: row ? row.dataset.step : null,
                           followed: !!at && at.top >= list.top - 1 && at.bottom <= list.bottom + 1});
    window.stopWatch = requestAnimationFrame(look);
  };
  look(); }"""


class Cell:
    """The module's simulator, store, server, page and an RTDE reader of the simulated arm."""

    def __init__(self, store, page, receive):
        self.store, self.page, self.receive = store, page, receive

    def at_rest(self) -> bool:
        return float(np.max(np.abs(self.receive.getActualQd()))) < 1e-3

    def moving(self) -> bool:
        return float(np.max(np.abs(self.receive.getActualQd()))) > 0.01

    def cli(self, *arguments: str) -> None:
        import subprocess

        subprocess.run(ur3dq_command(*arguments, store=self.store), capture_output=True, text=True, timeout=60,
                       env=environment(self.store.parent / "state"), check=True)


@pytest.fixture(scope="module")
def cell(browser, tmp_path_factory):
    import rtde_receive

    from screen_support import START_Q
    from sim_ursim.launch import simulator_process

    store = tmp_path_factory.mktemp("operator") / "poses.json"
    hundred_step_store(store)
    with simulator_process(model="ur3", initial_q=list(START_Q)) as simulator, \
            served(simulator.host, store, ARTIFACTS / "screen-operator.log") as server:
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        context = browser.new_context(viewport=SIZE, has_touch=True)
        page = context.new_page()
        errors = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(server.url)
        try:
            yield Cell(store, page, receive)
        finally:
            receive.disconnect()
            context.close()
        assert errors == [], errors


def test_every_control_is_big_enough_for_a_finger(cell):
    page = cell.page
    expect(page.locator('[data-step="p099"]')).to_have_count(1, timeout=20000)
    boxes = page.evaluate(CONTROL_BOXES)
    assert len(boxes) > 100, boxes
    small = [box for box in boxes if box["height"] < FINGER]
    assert not small, f"controls under {FINGER} px high at 1024×768: {small}"
    narrow = [box for box in boxes if box["width"] < FINGER]
    assert not narrow, f"controls under {FINGER} px wide at 1024×768: {narrow}"


def test_power_on_and_brake_release(cell):
    page = cell.page
    for name in ("Power on", "Brake release"):
        expect(button(page, name)).to_be_enabled(timeout=20000)
        button(page, name).click()
    expect(page.locator("#robot-mode")).to_have_text("RUNNING", timeout=20000)
    page.wait_for_function("document.body.dataset.armDrawn === 'true'", timeout=20000)


def hold_space_on_j1_minus(cell) -> None:
    """Focus J1-, press Space (and keep it down) until the arm moves."""
    page = cell.page
    expect(page.locator(J1_MINUS)).to_be_enabled(timeout=10000)
    assert wait_for(cell.at_rest, timeout=3.0)
    page.locator(J1_MINUS).focus()
    page.keyboard.down(" ")
    assert wait_for(cell.moving, timeout=3.0), "Space on J1- did not jog"


def stays_at_rest(cell, seconds: float = 0.5) -> bool:
    """The arm at rest within a second, and not moving again for `seconds` more."""
    if not wait_for(cell.at_rest, timeout=1.0):
        return False
    q = np.array(cell.receive.getActualQ())
    return not wait_for(lambda: not np.allclose(cell.receive.getActualQ(), q, atol=1e-5), timeout=seconds)


def test_a_keyboard_jog_ends_when_the_focus_moves_and_the_key_comes_up_elsewhere(cell):
    page = cell.page
    hold_space_on_j1_minus(cell)
    page.keyboard.press("Shift+Tab")                  # the focus leaves the held button: the jog ends there
    assert page.evaluate("document.activeElement.id") == "jog-speed"
    page.keyboard.up(" ")                             # and the key comes up on another element
    assert stays_at_rest(cell), "the jog went on after Space was released on another element"
    expect(page.locator(J1_MINUS)).not_to_have_class("held")
    expect(page.locator("#robot-line")).not_to_contain_text("jog", timeout=3000)


def test_a_keyboard_jog_ends_when_the_operator_clicks_elsewhere(cell):
    page = cell.page
    hold_space_on_j1_minus(cell)
    page.locator("#teach-title").click()              # Space still down: the click takes the focus away
    try:
        assert stays_at_rest(cell), "the jog went on after a click elsewhere"
    finally:
        page.keyboard.up(" ")
    assert stays_at_rest(cell)


def test_stop_stays_in_view_through_a_run_of_a_long_program(cell):
    page = cell.page
    set_speed_slider(page, 100)
    button(page, "Run").click()
    expect(page.locator("#ask")).to_contain_text("Run 100 steps")
    page.evaluate(WATCH_STOP)
    button(page, "Yes").click()
    page.wait_for_function("document.querySelector('#steps [aria-current=\"step\"]')?.dataset.step >= 'p016'",
                           timeout=60000)
    button(page, "Stop").click()
    expect(page.locator("#program-state")).to_have_text("STOPPED", timeout=5000)
    boxes = page.evaluate("cancelAnimationFrame(window.stopWatch) || window.stopBoxes")
    page.screenshot(path=str(ARTIFACTS / "screen-operator-stopped-1024.png"))
    steps = [box["step"] for box in boxes if box["step"]]
    assert "p001" in steps and "p015" in steps, steps
    out = [box for box in boxes if box["top"] < 0 or box["bottom"] > SIZE["height"] or box["left"] < 0
           or box["right"] > SIZE["width"]]
    assert not out, f"Stop left the viewport during the run: {out[:3]}"
    assert len({box["header"] for box in boxes}) == 1, "the header changed its height during the run"
    assert {box["panels"] for box in boxes} == {boxes[0]["panels"]}, "the panels scrolled during the run"
    assert [box for box in boxes if box["step"]][-1]["followed"], "the list did not show the running step"
    assert wait_for(cell.at_rest, timeout=2.0)


def test_typing_in_the_motion_editor_survives_an_edit_made_elsewhere(cell):
    page = cell.page
    page.locator('[data-step="p002"]').click()
    page.locator("#edit-move").select_option("linear")
    page.locator("#edit-speed").fill("250")
    cell.cli("poses", "add-step", "--after", "p003", "wait", "100ms")
    expect(page.locator('[data-step="wait-1"]')).to_have_count(1, timeout=5000)
    expect(page.locator("#edit-move")).to_have_value("linear")
    expect(page.locator("#edit-speed")).to_have_value("250")
    button(page, "Apply").click()
    expect(page.locator('[data-step="p002"] .speed')).to_have_text("250 mm/s", timeout=3000)
    assert PoseStore(cell.store).get_step("p002").motion.speed == pytest.approx(0.25)
    page.locator("#edit-speed").fill("300")           # typed, then the step itself changes: the page says so
    cell.cli("poses", "set", "p002", "--speed", "120mm/s")
    expect(page.locator("#edit-speed")).to_have_value("120 mm/s", timeout=5000)
    expect(page.locator("#notice")).to_contain_text("'p002' was changed elsewhere")
    page.locator("#edit-speed").fill("300")           # typed, then the step goes
    cell.cli("poses", "rm", "p002", "--yes")
    expect(page.locator('[data-step="p002"]')).to_have_count(0, timeout=5000)
    expect(page.locator("#notice")).to_contain_text("'p002' is gone: its motion edit was not applied")


def test_enter_in_a_text_dialog_is_ok_and_in_a_motion_question_is_no(cell):
    page = cell.page
    page.locator('[data-step="p003"]').click()
    button(page, "Rename").click()
    page.locator("#ask input[name=new]").fill("above-part")
    page.keyboard.press("Enter")
    expect(page.locator('[data-step="above-part"]')).to_have_count(1, timeout=5000)
    expect(page.locator("#ask")).not_to_have_attribute("open", "")
    button(page, "Record pose").click()
    page.locator("#ask input[name=name]").fill("by-enter")
    page.keyboard.press("Enter")
    expect(page.locator('[data-step="by-enter"]')).to_have_count(1, timeout=5000)
    assert PoseStore(cell.store).get("by-enter") is not None
    page.locator('[data-step="p005"]').click()
    button(page, "Move here").click()
    expect(page.locator("#ask")).to_contain_text("Move the arm to 'p005'")
    page.evaluate("document.getElementById('notice').textContent = ''")
    page.keyboard.press("Enter")
    expect(page.locator("#notice")).to_have_text("answered no: nothing done.", timeout=5000)
    assert cell.at_rest()


def focused_step(page) -> str | None:
    return page.evaluate("document.activeElement.dataset.step || null")


def test_the_steps_are_chosen_and_edited_from_the_keyboard(cell):
    page = cell.page
    expect(page.locator("#steps")).to_have_attribute("role", "listbox")
    page.locator('[data-step="p000"]').click()
    page.locator("#add-message").focus()
    for _ in range(5):                                # on past the motion editor to the list: one Tab stop
        page.keyboard.press("Tab")
        if focused_step(page):
            break
    assert focused_step(page) == "p000"
    expect(page.locator('[data-step="p000"]')).to_have_attribute("role", "option")
    order = ["p000", "p001", "above-part", "wait-1", "p004"]   # p002 deleted, p003 renamed, a wait added
    for name in order[1:]:
        page.keyboard.press("ArrowDown")
        assert focused_step(page) == name
        expect(page.locator(f'[data-step="{name}"]')).to_have_attribute("aria-selected", "true")
    expect(page.locator('#steps [aria-selected="true"]')).to_have_count(1)
    expect(page.locator("#motion-editor")).to_be_visible()
    expect(page.locator("#edit-move")).to_have_value("joint")
    cell.cli("poses", "add-step", "--after", "p010", "message", "from the shell")   # the list is drawn again
    expect(page.locator('[data-step="message-1"]')).to_have_count(1, timeout=5000)
    assert focused_step(page) == "p004", "the focus left the list when it was drawn again"
    page.keyboard.press("End")
    assert focused_step(page) == page.locator("#steps li").last.get_attribute("data-step")
    page.keyboard.press("Home")
    page.keyboard.press("ArrowDown")
    assert focused_step(page) == "p001"
    button(page, "Down").focus()                      # Down by the keyboard: the step moves, still selected
    page.keyboard.press("Enter")
    expect(page.locator("#steps li").nth(2)).to_have_attribute("data-step", "p001", timeout=5000)
    expect(page.locator('[data-step="p001"]')).to_have_attribute("aria-selected", "true")
    button(page, "Undo").focus()
    page.keyboard.press("Enter")
    expect(page.locator("#steps li").nth(1)).to_have_attribute("data-step", "p001", timeout=5000)
