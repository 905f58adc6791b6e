"""urx 0.11's own Robot class in the project's environment: getl, movel and translate need the math3d release urx
was written for (pyproject.toml pins it), against the simulator with the layouts urx 0.11 reads (3.4)."""
import numpy as np
import pytest
import urx

from robot_target import simulator_only
from sim_ursim.launch import running_simulator

pytestmark = [
    simulator_only("urx's movel(wait=True) needs a 3.4 controller's robot mode layout"),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),  # inside urx 0.11 itself
    pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning"),
]

START = [0.3, -1.2, 1.0, -1.4, -1.5, 0.2]


@pytest.fixture
def urx_robot():
    """urx.Robot on a powered 3.4.5 simulator with the arm at START, closed before the simulator stops."""
    with running_simulator(model="ur3", version="3.4.5") as simulator:
        simulator.controller.power_up()
        assert simulator.controller.movej(START, a=3.0, v=2.0).wait(timeout=10)
        robot = urx.Robot(simulator.host)
        # urx reads 30002 with a 0.5 s timeout and its reader thread dies on the first one; an in-process
        # simulator on a loaded machine can pause that long (tests/sim_ursim/test_urx.py, connect)
        robot.secmon._s_secondary.settimeout(5.0)
        try:
            yield robot, simulator.controller
        finally:
            robot.close()


def test_getl_movel_and_translate_of_urx_robot(urx_robot):
    robot, controller = urx_robot
    start = robot.getl(wait=True)
    np.testing.assert_allclose(start, controller.state().actual_tcp_pose, atol=1e-9)
    goal = list(start)
    goal[2] += 0.03
    robot.movel(goal, acc=1.0, vel=0.2, wait=True)
    np.testing.assert_allclose(controller.state().actual_tcp_pose, goal, atol=2e-3)
    robot.translate((0.0, 0.0, -0.03), acc=1.0, vel=0.2, wait=True)
    np.testing.assert_allclose(controller.state().actual_tcp_pose, start, atol=2e-3)
    np.testing.assert_allclose(robot.get_pose().pose_vector, controller.state().actual_tcp_pose, atol=1e-6)
