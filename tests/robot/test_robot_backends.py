"""Behaviour of the driver on each backend against a real controller interface (sim_ursim or UR3DQ_TEST_HOST)."""
import math
import threading
import time

import numpy as np
import pytest

import ur3dq.robot
from polling import wait_for
from ur3dq.errors import ProgramError, RobotError, SafetyCheckError
from ur3dq.robot import motion
from ur3dq.robot.primary_client import PrimaryClient


def test_connect_identifies_the_model_and_reads_its_kinematics(robot):
    assert robot.model_name == "ur3" and robot.model.calibrated
    assert len(robot.controller_version) == 4
    assert robot.model.dh.a[1] == pytest.approx(-0.24365, abs=0.01)


def test_fk_of_the_joints_is_the_controllers_tcp(robot):
    ours = robot.model.fk(robot.joints())
    metres, radians = ours.distance(robot.tcp_pose())
    assert metres < 1e-5 and radians < 1e-4
    assert np.allclose(robot.tcp_pose().to_ur_pose()[:3], robot.tcp_pose_vector()[:3])


def test_state_reports_modes_and_speed(robot):
    status = robot.state()
    assert status.robot_mode_name == "RUNNING" and status.safety_mode_name == "NORMAL"
    assert not status.program_running and not status.protective_stopped and not status.emergency_stopped
    assert 0 < status.target_speed_fraction <= 1 and status.age < 1.0
    assert status.joints.shape == (6,) and status.tcp_pose.shape == (6,)


def test_movej_blocks_for_the_motion_and_ends_at_rest_on_target(robot, home):
    target = home + np.array([0.3, -0.2, 0.25, 0.1, 0.2, -0.4])
    expected = motion.movej_duration(robot.joints(), target, 1.4, 1.05)
    wall = robot.movej(target, a=1.4, v=1.05)
    assert wall >= 0.9 * expected  # it did wait for the arm
    status = robot.state()
    assert np.max(np.abs(status.joints - target)) < 2e-3 and np.max(np.abs(status.joint_speeds)) < 5e-3
    # movej returns on the controller's "program stopped" message; the state stream agrees a cycle later
    # (within 10 Hz for urx's primary data).
    assert wait_for(lambda: not robot.state().program_running, timeout=1.0)


def test_movej_to_the_current_joints_returns_at_once(robot):
    assert robot.movej(robot.joints()) == 0.0


def test_movej_pose_goes_through_ik_and_reaches_the_pose(robot, home):
    goal = robot.model.fk(home + np.array([0.2, 0.1, -0.1, 0.1, 0.1, 0.1]))
    robot.movej_pose(goal)
    metres, radians = robot.tcp_pose().distance(goal)
    assert metres < 1e-3 and radians < 1e-2


def test_movej_path_runs_one_blended_program_to_the_last_target(robot, home):
    targets = [home + np.array([0.3, 0, 0, 0, 0, 0]), home + np.array([0.3, -0.3, 0.3, 0, 0, 0]),
               home + np.array([0, -0.3, 0.3, 0.2, 0, 0])]
    stopping = motion.path_duration(robot.joints(), targets, 1.4, 1.05)
    listener = PrimaryClient(robot.host)  # a second 30001 client sees every program the controller starts
    messages = listener.watch()
    # from its version message on: a program started before the controller greeted this client is not its news
    assert listener.wait_for(lambda client: client.version is not None, 5.0)
    try:
        wall = robot.movej_path(targets, blend=0.02, a=1.4, v=1.05)
        time.sleep(0.05)
    finally:
        listener.close()
    started = [m for m in list(messages.queue) if getattr(m, "title", "").endswith("_STARTED")]
    assert len(started) == 1 and started[0].text.startswith("ur3dq_move_")
    assert np.max(np.abs(robot.joints() - targets[-1])) < 2e-3
    assert wall < stopping + 1.0


def test_speed_and_acceleration_are_clamped_to_the_model(robot, home):
    target = home + np.array([1.0, 0, 0, 0, 0, 0])
    a, v = float(np.min(robot.model.max_joint_acceleration)), float(robot.model.max_joint_speed[0])
    wall = robot.movej(target, a=1000.0, v=1000.0)
    assert wall >= 0.9 * motion.movej_duration(home, target, a, v)


@pytest.mark.parametrize("bad, fragment", [
    ([0, 0, math.nan, 0, 0, 0], "finite"),
    ([0, 0, 0, 0, 0], "six joint"),
    ([7.0, -1.5, 1.2, -1.2, -1.5, 0], "outside its limits"),
])
def test_bad_targets_are_refused_before_sending(robot, bad, fragment):
    before = robot.joints()
    with pytest.raises(SafetyCheckError, match=fragment):
        robot.movej(bad)
    time.sleep(0.1)  # a program, had one been sent, would be running by now
    assert not robot.state().program_running
    assert np.allclose(robot.joints(), before, atol=1e-6)


def test_a_large_joint_swing_is_refused(robot, home):
    with pytest.raises(SafetyCheckError, match="joint 6 would travel"):
        robot.movej(home + np.array([0, 0, 0, 0, 0, 4.0]))


def test_the_travel_bound_is_configurable(arm_host, backend, home):
    with ur3dq.robot.connect(arm_host, backend=backend, max_joint_travel=0.1) as robot:
        assert robot.model is not None   # connected
        with pytest.raises(SafetyCheckError, match="0.1000 rad per move"):
            robot.movej(robot.joints() + np.array([0.2, 0, 0, 0, 0, 0]))


def test_a_target_inconsistent_with_its_pose_is_refused(robot, home):
    pose = robot.model.fk(home)
    with pytest.raises(SafetyCheckError, match="does not reach the pose"):
        robot.movej(home + np.array([0.05, 0, 0, 0, 0, 0]), expected_pose=pose)


def test_a_bad_blend_is_refused(robot, home):
    with pytest.raises(SafetyCheckError, match="blend"):
        robot.movej_path([home], blend=-0.1)


def test_stop_decelerates_a_running_motion(robot, home):
    target = home + np.array([2.5, 0, 0, 0, 0, 0])
    outcome = {}

    def move():
        try:
            robot.movej(target, a=1.4, v=1.05)
        except RobotError as error:
            outcome["error"] = error

    mover = threading.Thread(target=move)
    mover.start()
    assert wait_for(lambda: np.max(np.abs(robot.state().joint_speeds)) > 0.5, timeout=5.0)   # well under way
    robot.stop()
    mover.join(timeout=10)
    assert isinstance(outcome.get("error"), ProgramError)
    assert wait_for(lambda: np.max(np.abs(robot.state().joint_speeds)) < 5e-3, timeout=2.0)
    status = robot.state()
    assert abs(status.joints[0] - target[0]) > 0.3


def test_set_tcp_changes_the_controllers_tcp_and_the_model(robot):
    before = robot.model.tcp.to_ur_pose()
    try:
        robot.set_tcp([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
        assert np.allclose(robot.model.tcp.to_ur_pose(), [0, 0, 0.12, 0, 0, 0], atol=1e-12)
        # the model changes at once; the streamed TCP pose shows the new TCP from the next state package on
        assert wait_for(lambda: robot.model.fk(robot.joints()).distance(robot.tcp_pose())[0] < 1e-5, timeout=1.0)
    finally:  # the module's other tests share this controller
        robot.set_tcp(list(before))


def test_teach_mode_on_and_off(robot, home):
    robot.teach_mode(True)  # raises ProgramError unless the controller reports TEACH control mode within 2 s
    robot.teach_mode(False)  # ... and POSITION again
    target = home + np.array([0.1, 0, 0, 0, 0, 0])
    robot.movej(target)  # moves normally again
    np.testing.assert_allclose(robot.joints(), target, atol=1e-4)


def test_unknown_backend_and_wrong_model_are_refused(arm_host):
    with pytest.raises(ValueError, match="backend"):
        ur3dq.robot.connect(arm_host, backend="ros")
    with pytest.raises(RobotError, match="ur5.* requested but the controller is a ur3"):
        ur3dq.robot.connect(arm_host, model="ur5")


def test_no_controller_gives_a_connection_error():
    from ur3dq.errors import RobotConnectionError

    with pytest.raises(RobotConnectionError, match="primary interface"):
        ur3dq.robot.connect("127.254.254.254")
