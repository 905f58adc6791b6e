"""Hand-guided recording through teach mode, and an e-series controller, on sim_ursim."""
import numpy as np
import pytest

import ur3dq.robot
from polling import wait_for
from robot_target import simulator_only
from robot_test_support import HOME, inject, ready, simulator_with
from ur3dq.errors import RobotError

pytestmark = simulator_only("moving the arm by hand")


def test_teach_mode_records_a_hand_guided_pose(arm_host, backend):
    with ur3dq.robot.connect(arm_host, backend=backend) as robot:
        ready(robot)
        guided = HOME + np.array([0.3, -0.2, 0.1, 0.0, 0.4, -0.5])
        robot.teach_mode(True)
        inject(arm_host, "move-by-hand", q=list(guided))
        # the state streams show the hand-guided pose within a cycle (10 Hz for urx); its TCP may come a packet later
        expected_tcp = robot.model.fk(guided)
        assert wait_for(lambda: np.allclose(robot.joints(), guided, atol=1e-9)
                        and robot.tcp_pose().distance(expected_tcp)[0] < 1e-6, timeout=2.0)
        recorded_joints, recorded_pose = robot.joints(), robot.tcp_pose()
        robot.teach_mode(False)
        assert np.allclose(recorded_joints, guided, atol=1e-9)
        assert robot.model.fk(recorded_joints).distance(recorded_pose)[0] < 1e-6
        robot.movej(HOME)  # the arm takes commands again
        robot.movej_pose(recorded_pose)  # and goes back to what was recorded
        assert robot.tcp_pose().distance(recorded_pose)[0] < 1e-3


def test_hand_guiding_is_refused_outside_teach_mode(arm_host):
    with ur3dq.robot.connect(arm_host) as robot:
        ready(robot)
        with pytest.raises(AssertionError, match="freedrive"):
            inject(arm_host, "move-by-hand", q=list(HOME + 0.1))


def test_e_series_controller():
    with simulator_with(model="ur3e") as simulator, ur3dq.robot.connect(simulator.host) as robot:
        assert robot.model_name == "ur3e" and robot.controller_version[0] == 5
        assert robot.serial_number is not None and robot.serial_number.isdigit()  # PolyScope 5.6+ tells it
        ready(robot)
        assert robot.model.fk(robot.joints()).distance(robot.tcp_pose())[0] < 1e-6
        with pytest.raises(RobotError, match="requested but the controller is a ur3e"):
            ur3dq.robot.connect(simulator.host, model="ur3")
