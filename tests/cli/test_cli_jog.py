"""`ur3dq jog` through a pseudo-terminal of 80×24, against a simulator process (read with ur_rtde).

A key press moves the arm by the step (within 1e-3 rad / 0.5 mm), keys held down (typed ahead) make one step,
nothing moves without a key, `r` records the pose (and says when it is the same spot as another), `q` quits.
"""
import math
import time

import numpy as np
import pytest

from cli_support import Terminal
from robot_target import simulator_only
from ur3dq.kinematics import robot_model
from ur3dq.store import PoseStore

pytestmark = simulator_only("placing the arm by hand")

START = np.array([0.2, -1.3, 1.4, -1.7, -1.5708, 0.1])
MODEL = robot_model("ur3")


@pytest.fixture
def terminal(arm, tmp_path):
    arm.place(START)
    shown = Terminal(tmp_path, "--host", arm.host, "jog")
    try:
        shown.wait_for("ur3dq jog - ur3 at")
        yield shown
    finally:
        shown.close()


def at_rest(arm, timeout=10.0):
    deadline = time.monotonic() + timeout
    while np.max(np.abs(arm.joint_speeds())) > 1e-9:
        assert time.monotonic() < deadline, "the arm does not come to rest"
        time.sleep(0.01)
    return arm.joints()


def test_a_joint_key_moves_one_step_and_nothing_moves_without_a_key(arm, terminal):
    before = arm.joints()
    terminal.press("2")
    terminal.wait_for("Axis J2.")
    terminal.press("+")
    terminal.wait_for("Moved J2+ by 1 °")
    after = at_rest(arm)
    expected = before.copy()
    expected[1] += math.radians(1.0)
    np.testing.assert_allclose(after, expected, atol=1e-3)
    np.testing.assert_allclose(np.delete(after, 1), np.delete(before, 1), atol=1e-9)
    time.sleep(1.0)   # no key: nothing moves
    np.testing.assert_allclose(arm.joints(), after, atol=1e-9)
    terminal.press("s")   # 10°, and five key presses typed while the first step runs: one step
    terminal.wait_for("Step 10.")
    terminal.press("-----")
    terminal.wait_for("Moved J2- by 10 °")
    time.sleep(1.0)
    held = at_rest(arm)
    np.testing.assert_allclose(held[1], after[1] - math.radians(10.0), atol=1e-3)
    terminal.press("q")
    assert terminal.process.wait(10) == 0


def test_tcp_keys_move_the_tcp_in_the_base_and_the_tool_frame(arm, terminal):
    terminal.press("m")
    terminal.wait_for("Mode TCP base")
    terminal.press("3")   # Z
    before = arm.tcp_pose()
    terminal.press("+")
    terminal.wait_for("Moved Z+ by 1 mm")
    at_rest(arm)
    after = arm.tcp_pose()
    np.testing.assert_allclose(after[:3] - before[:3], [0.0, 0.0, 0.001], atol=5e-4)
    np.testing.assert_allclose(after[3:], before[3:], atol=1e-3)
    terminal.press("m")
    terminal.wait_for("Mode TCP tool")
    terminal.press("1")   # X of the tool
    tool_x = MODEL.fk(arm.joints()).rotation.rotate([1.0, 0.0, 0.0])
    terminal.press("-")
    terminal.wait_for("Moved X- by 1 mm")
    at_rest(arm)
    np.testing.assert_allclose(arm.tcp_pose()[:3] - after[:3], -0.001 * np.asarray(tool_x), atol=5e-4)
    terminal.press("q")
    assert terminal.process.wait(10) == 0


def test_r_records_the_pose_and_names_the_same_spot(arm, terminal, tmp_path):
    terminal.press("r")
    terminal.wait_for("Recorded 'pose-1'.")
    terminal.press("r")
    terminal.wait_for("Recorded 'pose-2' (the same spot as 'pose-1').")
    terminal.press("q")
    assert terminal.process.wait(10) == 0
    stored = PoseStore(tmp_path / "poses.json").load()
    assert [pose.name for pose in stored] == ["pose-1", "pose-2"]
    np.testing.assert_allclose(stored[0].joints, START, atol=1e-9)


def test_move_to_plans_checks_asks_and_moves_to_a_recorded_pose(arm, run_cli, tmp_path):
    target = START + np.array([0.4, -0.1, 0.1, 0.0, 0.0, 0.2])
    arm.place(target)
    assert run_cli("--host", arm.host, "record-pose", "--name", "pick", "--yes").returncode == 0
    arm.place(START)
    declined = run_cli("--host", arm.host, "move-to", "pick", input="\n")   # the question defaults to No
    assert declined.returncode == 1 and "Move to 'pick': a joint move at" in declined.stderr, declined.stderr
    assert "Path check (no cell file): clear" in declined.stderr
    np.testing.assert_allclose(arm.joints(), START, atol=1e-9)
    moved = run_cli("--host", arm.host, "move-to", "pick", "--yes")
    assert moved.returncode == 0, moved.stderr
    assert "At 'pick': the TCP is 0.000 mm and 0.0000 rad from it" in moved.stdout, moved.stdout
    np.testing.assert_allclose(arm.joints(), target, atol=1e-3)
    missing = run_cli("--host", arm.host, "move-to", "nowhere", "--yes")
    assert missing.returncode == 3 and "no pose named 'nowhere'" in missing.stderr
