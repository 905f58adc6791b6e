"""The driver's straight-line moves, digital I/O, jog steps, and pause/resume, on sim_ursim with both backends.

What the driver says is checked against what the simulator reports through its own control channel or ur_rtde."""
import math
import threading
import time

import numpy as np
import pytest

from polling import wait_for
from robot_target import simulator_only
from robot_test_support import HOME, inject, simulator_state
from ur3dq import DualQuaternion
from ur3dq.errors import RobotError, SafetyCheckError
from ur3dq.robot.jog_steps import JogStep

pytestmark = simulator_only("reading the simulator's own state")


def test_movel_goes_on_a_straight_line_to_a_pose(sim_robot):
    host, robot = sim_robot
    start = robot.tcp_pose()
    below = DualQuaternion.from_translation([0.0, 0.0, -0.05]) * start   # 5 cm down in the base frame
    seen = []
    mover = threading.Thread(target=lambda: seen.append(robot.movel(below, v=0.1)))
    mover.start()
    positions = []   # the TCP on the way, from the simulator's own joints
    while mover.is_alive():
        positions.append(robot.model.fk(np.array(simulator_state(host)["q"])).translation)
        time.sleep(0.02)
    mover.join()
    assert seen and seen[0] > 0.3   # it waited for the move: 5 cm at 0.1 m/s
    assert robot.tcp_pose().distance(below)[0] < 5e-4
    # every TCP position seen on the way lies on the segment from start to target (a movej would bow out)
    line = below.translation - start.translation
    off_line = [np.linalg.norm(np.cross(p - start.translation, line)) / np.linalg.norm(line) for p in positions]
    assert max(off_line) < 1e-4, max(off_line)


def test_movep_and_a_pose_vector_target(sim_robot):
    _, robot = sim_robot
    vector = robot.tcp_pose_vector() + [0.03, -0.02, 0.0, 0.0, 0.0, 0.0]
    robot.movep(vector, v=0.1)
    np.testing.assert_allclose(robot.tcp_pose_vector()[:3], vector[:3], atol=5e-4)


def test_an_unreachable_line_is_refused_before_anything_moves(sim_robot):
    host, robot = sim_robot
    far = DualQuaternion.from_translation([0.0, 0.0, 2.0]) * robot.tcp_pose()
    with pytest.raises(ValueError, match="reach|unreachable|too far"):
        robot.movel(far)
    assert not simulator_state(host)["program_running"]
    np.testing.assert_allclose(robot.joints(), HOME, atol=1e-9)


def test_outputs_set_and_inputs_read_through_the_controller(sim_robot):
    host, robot = sim_robot
    robot.set_tool_digital_out(0, True)
    robot.set_digital_out(3, True)
    assert robot.digital_out(0, "tool") and robot.digital_out(3)
    assert set(robot.outputs_on()) == {("tool", 0), ("standard", 3)}
    robot.set_tool_digital_out(0, False)
    robot.set_digital_out(3, False)
    assert robot.outputs_on() == []
    inject(host, "set-digital-input", pin=2, on=True)   # the simulated sensor
    assert wait_for(lambda: robot.digital_in(2), timeout=2.0)
    inject(host, "set-digital-input", pin=2, on=False)
    assert wait_for(lambda: not robot.digital_in(2), timeout=2.0)
    with pytest.raises(ValueError, match="does not exist"):
        robot.set_tool_digital_out(2, True)


@pytest.mark.parametrize("step, joint_change, tcp_change", [
    (JogStep("J2", -1, math.radians(1.0)), (1, -math.radians(1.0)), None),
    (JogStep("Z", +1, 0.001), None, np.array([0.0, 0.0, 0.001])),
    (JogStep("X", -1, 0.01, frame="tool"), None, None),
])
def test_a_jog_step_moves_by_the_step_and_stops(sim_robot, step, joint_change, tcp_change):
    host, robot = sim_robot
    before_q, before_tcp = robot.joints(), robot.tcp_pose()
    robot.jog(step, speed=0.05)
    after_q = np.array(simulator_state(host)["q"])
    assert not simulator_state(host)["program_running"]   # nothing runs on once the step returned
    if joint_change is not None:
        expected = before_q.copy()
        expected[joint_change[0]] += joint_change[1]
        np.testing.assert_allclose(after_q, expected, atol=1e-6)
    moved = robot.model.fk(after_q).translation - before_tcp.translation
    if tcp_change is not None:
        np.testing.assert_allclose(moved, tcp_change, atol=5e-4)
    if step.frame == "tool":   # along the tool's own -x axis
        tool_x = before_tcp.rotation.rotate([1.0, 0.0, 0.0])
        np.testing.assert_allclose(moved, -0.01 * np.asarray(tool_x), atol=5e-4)


def test_a_jog_step_larger_than_the_bound_is_refused():
    with pytest.raises(ValueError, match="step must be"):
        JogStep("Z", +1, 0.5)


def test_pause_holds_the_arm_on_its_path_past_the_motion_timeout_and_resume_finishes(sim_robot):
    """Paused longer than the move's own timeout (its trapezoid × 1.5 + 1 s), the watch neither times out nor
    mistakes the pause for an end; resumed, the move ends on its target."""
    host, robot = sim_robot
    target = HOME + np.array([0.5, 0, 0, 0, 0, 0])
    outcome = []
    mover = threading.Thread(target=lambda: outcome.append(robot.movej(target, v=0.4, a=2.0)))
    mover.start()
    assert wait_for(lambda: abs(robot.joints()[0] - HOME[0]) > 0.1, timeout=5)
    assert robot.pause() == "paused"
    assert wait_for(lambda: np.max(np.abs(robot.state().joint_speeds)) < 1e-6, timeout=2)
    held = robot.joints()
    time.sleep(3.5)   # the move takes ~1.45 s: its timeout is ~3.2 s
    assert mover.is_alive() and not outcome
    np.testing.assert_allclose(robot.joints(), held, atol=1e-9)
    assert simulator_state(host)["program_running"]
    robot.resume()
    mover.join(10)
    assert outcome, "the move did not finish after resume"
    np.testing.assert_allclose(robot.joints(), target, atol=2e-3)


def test_pause_with_nothing_running_falls_back_to_a_stop_and_resume_is_refused(sim_robot):
    _, robot = sim_robot
    assert robot.pause() == "stopped"
    with pytest.raises(RobotError, match="no program is paused"):
        robot.resume()


def test_a_jog_speed_must_be_a_positive_number(sim_robot):
    _, robot = sim_robot
    with pytest.raises(SafetyCheckError, match="jog speed"):
        robot.jog(JogStep("J1", 1, 0.01), speed=-1)
