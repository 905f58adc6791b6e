"""The screen server's safety rules, in a real headless Chromium against `ur3dq serve` and a powered simulator:
Stop and Pause from every open page, a run stopped because its page closed says so (and a reloaded page shows it),
freedrive ends with the page that turned it on, a question about a program that changed is withdrawn, the motion
editor keeps what it does not show and refuses speeds out of range, typed pins and loop counts are whole numbers in
range, and a store file that does not read stops Check, Run and Move here until it is repaired."""
import subprocess

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
    notice_after,
    served,
    set_speed_slider,
    ur3dq_command,
)
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

pytestmark = [pytest.mark.browser, simulator_only("the screen's safety tests drive sim_ursim")]

PROGRAM = ["p1", "p2", "p3"]
# A raw command from a page's own origin, on a socket of its own that takes control first (as a script could).
RAW_COMMAND = """([cmd, args]) => new Promise((done) => {
  const socket = new WebSocket(new URL('/ws', location.href).href.replace('http', 'ws'));
  socket.onopen = () => { socket.send(JSON.stringify({type: 'take_control'}));
    socket.send(JSON.stringify({type: 'cmd', cmd, args, id: 1})); };
  socket.onmessage = (event) => { const m = JSON.parse(event.data);
    if (m.type === 'reply' && m.id === 1) { socket.close(); done(m); } }; })"""


class Cell:
    """The module's simulator, store, server, browser and an RTDE reader of the simulated arm."""

    def __init__(self, simulator, store, server, browser, receive):
        self.simulator, self.store, self.server, self.browser, self.receive = (simulator, store, server, browser,
                                                                               receive)

    def moving(self) -> bool:
        return float(np.max(np.abs(self.receive.getActualQd()))) > 0.01

    def at_rest(self) -> bool:
        return float(np.max(np.abs(self.receive.getActualQd()))) < 1e-3

    def cli(self, *arguments: str) -> subprocess.CompletedProcess:
        return subprocess.run(ur3dq_command(*arguments, store=self.store), capture_output=True, text=True,
                              timeout=60, env=environment(self.store.parent / "state"), check=True)

    def open_page(self):
        """A new page of the screen, once it shows the robot and who has control."""
        page = self.browser.new_page(viewport={"width": 1280, "height": 800})
        page.goto(self.server.url)
        page.wait_for_function("document.getElementById('robot-mode').textContent === 'RUNNING' && "
                               "document.getElementById('control-line').textContent !== ''", timeout=20000)
        return page


def holder_id(page) -> str:
    """The id ('page-N') of the page that has control, as a read-only `page` shows it."""
    expect(page.locator("#control-line")).to_contain_text("Read-only", timeout=5000)
    return page.locator("#control-line").text_content().split()[1]


@pytest.fixture(scope="module")
def cell(browser, tmp_path_factory):
    import rtde_receive

    from powered_simulator import powered_simulator

    folder = tmp_path_factory.mktemp("screen-safety")
    store = folder / "poses.json"
    model = robot_model("ur3")
    poses = []
    for name, turn in zip(PROGRAM, (0.0, 0.3, 0.6)):   # joint 1 turns 0.3 rad a move: seconds at a slow slider
        q = np.array(START_Q) + np.array([turn, 0, 0, 0, 0, 0])
        poses.append(Pose.from_dual_quaternion(name, model.fk(q), "ur3", joints=tuple(q)))
    PoseStore(store).add_many(poses)
    with powered_simulator(model="ur3", initial_q=list(START_Q)) as simulator, \
            served(simulator.host, store, ARTIFACTS / "screen-server-safety.log") as server:
        receive = rtde_receive.RTDEReceiveInterface(simulator.host)
        try:
            yield Cell(simulator, store, server, browser, receive)
        finally:
            receive.disconnect()


def start_run(cell, page, loops: str = "100") -> None:
    """Run the program `loops` times at a slow speed slider from `page` (answering yes), until the arm moves."""
    set_speed_slider(page, 10)
    page.locator("#loops").fill(loops)
    button(page, "Run").click()
    expect(page.locator("#ask")).to_contain_text("Run 3 steps")
    button(page, "Yes").click()
    assert wait_for(cell.moving, timeout=10), "the run did not start"


def test_every_page_may_stop_and_pause_a_run_and_the_log_names_it(cell):
    runner = cell.open_page()
    runner_id = None
    other = cell.open_page()
    try:
        runner_id = holder_id(other)
        start_run(cell, runner)
        expect(button(other, "Stop")).to_be_enabled(timeout=5000)       # read-only, yet it may stop the arm
        expect(button(other, "Pause")).to_be_enabled(timeout=5000)
        button(other, "Pause").click()
        expect(other.locator("#program-state")).to_have_text("PAUSED", timeout=5000)
        assert wait_for(cell.at_rest, timeout=3.0), "a read-only page's Pause did not stop the arm"
        button(runner, "Resume").click()
        assert wait_for(cell.moving, timeout=10)
        button(other, "Take control").click()                            # the page that ran it loses control...
        expect(runner.locator("#control-line")).to_contain_text("Read-only", timeout=5000)
        other_id = holder_id(runner)
        expect(button(runner, "Stop")).to_be_enabled(timeout=5000)       # ...and may still stop its run
        notice = notice_after(runner, lambda: button(runner, "Stop").click(), "Error", server=cell.server)
        assert f"stopped by the operator (Stop on {runner_id})" in notice, notice
        assert wait_for(cell.at_rest, timeout=3.0), "the arm did not stop on Stop"
        expect(runner.locator("#program-state")).to_have_text("STOPPED", timeout=5000)
        expect(other.locator("#notice")).to_contain_text(f"the last run: stopped by the operator (Stop on "
                                                         f"{runner_id})", timeout=5000)
        log = cell.server.log_text()
        assert f"[{runner_id}] {cell.simulator.host}: stopj sent." in log, log[-3000:]
        assert f"[{other_id}] {cell.simulator.host}: " in log, log[-3000:]    # its Pause
    finally:
        runner.close()
        other.close()


def test_a_run_stopped_because_its_page_closed_says_so_after_a_reload(cell):
    page = cell.open_page()
    try:
        expect(page.locator("#control-line")).to_have_text("You have control.", timeout=5000)
        start_run(cell, page)
        page.reload()
        assert wait_for(cell.at_rest, timeout=3.0), "the run went on after its page closed"
        expect(page.locator("#notice")).to_contain_text("the last run: stopped: the page that had control",
                                                        timeout=10000)
        assert "stopped by the operator" not in page.locator("#notice").text_content()
        expect(button(page, "Run")).to_be_enabled(timeout=10000)
    finally:
        page.close()
    log = cell.server.log_text()
    assert "the controlling page closed during run: stopping the arm" in log
    closed = [line for line in log.splitlines() if "the controlling page closed during run" in line][-1]
    assert closed.split()[1] != "[server]", closed


def test_freedrive_ends_when_the_page_that_turned_it_on_closes_or_loses_control(cell):
    for how in ("close", "take control"):
        owner, other = cell.open_page(), cell.open_page()
        try:
            expect(owner.locator("#control-line")).to_have_text("You have control.", timeout=5000)
            button(owner, "Freedrive").click()
            expect(other.locator("#freedrive")).to_have_attribute("aria-pressed", "true", timeout=5000)
            if how == "close":
                owner.close()
            else:
                button(other, "Take control").click()
            expect(other.locator("#freedrive")).to_have_attribute("aria-pressed", "false", timeout=5000)
        finally:
            owner.close()
            other.close()


def test_a_question_about_a_program_that_changed_is_withdrawn(cell):
    saved = cell.store.read_text()
    page = cell.open_page()
    try:
        set_speed_slider(page, 100)
        page.locator("#loops").fill("1")
        button(page, "Run").click()
        expect(page.locator("#ask")).to_contain_text("Run 3 steps ('p1' to 'p3') on the arm?")
        cell.cli("poses", "rm", "p3", "--yes")
        expect(page.locator("#notice")).to_contain_text("the program changed while the question (run) was open",
                                                        timeout=5000)
        expect(page.locator("#ask")).not_to_be_visible()
        assert cell.at_rest()
        page.locator('[data-step="p2"]').click()
        button(page, "Move here").click()
        expect(page.locator("#ask")).to_contain_text("Move the arm to 'p2'")
        cell.cli("poses", "rename", "p1", "start")
        expect(page.locator("#notice")).to_contain_text("the program changed", timeout=5000)
        expect(page.locator("#ask")).not_to_be_visible()
        assert cell.at_rest()
    finally:
        page.close()
        cell.store.write_text(saved)


def test_the_motion_editor_keeps_the_acceleration_it_does_not_show(cell):
    cell.cli("poses", "set", "p2", "--move", "linear", "--speed", "100mm/s", "--acceleration", "500mm/s^2")
    page = cell.open_page()
    try:
        page.locator('[data-step="p2"]').click()
        expect(page.locator("#edit-move")).to_have_value("linear", timeout=5000)
        page.locator("#edit-blend").fill("2")
        notice = notice_after(page, lambda: button(page, "Apply").click(), "set 'p2'")
        assert notice == "set 'p2' to a linear move", notice
        motion = PoseStore(cell.store).get_step("p2").motion
        assert motion.acceleration == pytest.approx(0.5) and motion.blend == pytest.approx(0.002)
        assert motion.speed == pytest.approx(0.1)
        page.locator("#edit-move").select_option("joint")                # a joint move: no linear acceleration
        page.locator("#edit-speed").fill("")
        notice_after(page, lambda: button(page, "Apply").click(), "set 'p2'")
        assert PoseStore(cell.store).get_step("p2").motion.acceleration is None
    finally:
        page.close()


def test_the_motion_editor_refuses_speeds_out_of_range_in_the_page_units(cell):
    cell.cli("poses", "set", "p2", "--move", "linear", "--speed", "100mm/s")
    page = cell.open_page()
    try:
        page.locator('[data-step="p2"]').click()
        expect(page.locator("#edit-move")).to_have_value("linear", timeout=5000)
        motion = PoseStore(cell.store).get_step("p2").motion
        for typed, shown in (("1e300", "1e+300 mm/s"), ("1e-9", "1e-09 mm/s")):
            page.locator("#edit-speed").fill(typed)
            notice = notice_after(page, lambda: button(page, "Apply").click(), "set 'p2'")
            assert notice == (f"Error: waypoint 'p2': speed {shown} is outside the ur3's range for a linear move, "
                              "1 mm/s to 1000 mm/s"), notice
            assert PoseStore(cell.store).get_step("p2").motion == motion
        page.locator("#unit-length").select_option("m")                  # the refusal is in the page's units
        expect(page.locator('[data-step="p2"] .speed')).to_have_text("0.1 m/s", timeout=5000)
        page.locator("#edit-speed").fill("5")
        notice = notice_after(page, lambda: button(page, "Apply").click(), "set 'p2'")
        assert "speed 5 m/s is outside the ur3's range for a linear move, 0.001 m/s to 1 m/s" in notice, notice
        page.locator("#unit-length").select_option("mm")
        expect(page.locator('[data-step="p2"] .speed')).to_have_text("100 mm/s", timeout=5000)
        assert PoseStore(cell.store).get_step("p2").motion == motion
    finally:
        page.close()


def test_pins_and_loop_counts_are_whole_numbers_in_range(cell):
    page = cell.open_page()
    try:
        before = cell.store.read_text()
        for typed in ("1.5", "", "abc", "1e300", "8"):
            button(page, "Add output").click()
            page.locator("#ask input[name=pin]").fill(typed)
            notice = notice_after(page, lambda: button(page, "OK").click(), "add")
            assert notice == f"Error: standard output pin: {typed!r} is not a whole number from 0 to 7", notice
        assert cell.store.read_text() == before
        button(page, "Add output").click()
        page.locator("#ask select[name=group]").select_option("tool")
        page.locator("#ask input[name=pin]").fill("2")
        notice = notice_after(page, lambda: button(page, "OK").click(), "add")
        assert notice == "Error: tool output pin: '2' is not a whole number from 0 to 1", notice
        for typed in ("2.5", "0", "1001"):
            page.locator("#loops").fill(typed)
            notice = notice_after(page, lambda: button(page, "Run").click(), "asked")
            assert notice == f"Error: loops: {typed!r} is not a whole number from 1 to 1000", notice
            expect(page.locator("#ask")).not_to_be_visible()
        assert cell.store.read_text() == before
    finally:
        page.close()


def test_a_store_that_does_not_read_stops_check_run_and_move_here_until_repaired(cell):
    page = cell.open_page()
    good = cell.store.read_text()
    try:
        page.locator('[data-step="p1"]').click()
        expect(button(page, "Run")).to_be_enabled(timeout=5000)
        expect(button(page, "Move here")).to_be_enabled()
        cell.store.write_text(good[:-40])                                # a truncated, hand-edited store
        error = page.locator("#store-error")
        expect(error).to_be_visible(timeout=5000)
        expect(error).to_contain_text(f"repair {cell.store}")
        expect(error).to_contain_text("does not read")
        for name in ("Run", "Check", "Move here"):
            expect(button(page, name)).to_be_disabled()
        for command in ("check", "run", "move_here"):                   # refused by the server too
            reply = page.evaluate(RAW_COMMAND, [command, {"name": "p1"}])
            assert not reply["ok"] and "The program's file does not read" in reply["error"], (command, reply)
        cell.store.write_text(good)
        expect(error).to_be_hidden(timeout=5000)
        button(page, "Take control").click()                             # the raw socket took it
        expect(button(page, "Run")).to_be_enabled(timeout=5000)
        expect(button(page, "Check")).to_be_enabled()
    finally:
        cell.store.write_text(good)
        page.close()
