"""A motion returns only once the controller's state agrees that its program ended: the state read right after it
shows no program running. The controller announces the end (its key message) a state cycle before its state stream
shows it (RTDE: 8 ms on a CB3, 2 ms on an e-series; the primary interface the urx backend reads: up to 0.1 s)."""
import numpy as np

import ur3dq.robot
from robot_target import simulator_only
from robot_test_support import HOME, ready, simulator_with
from ur3dq import urscript

ROUNDS = 25   # each a short movej and a run_script of a zero-length move: 50 programs


def programs_still_running_after_return(robot, start):
    """Run ROUNDS short movej from `start` (the arm's joints) and after each a run_script of a zero-length move (a
    program shorter than a state cycle), reading the state as soon as each returns: the names of those it showed
    still running."""
    still_running = []
    for index in range(ROUNDS):
        target = start + np.array([0.005 * (1 - index % 2), 0, 0, 0, 0, 0])   # there and back
        robot.movej(target)
        if robot.state().program_running:
            still_running.append(f"movej {index}")
        name = urscript.new_program_name("end")
        robot.run_script(name, urscript.movej_program(name, [target], 1.4, 1.05), target, duration=0.0)
        if robot.state().program_running:
            still_running.append(f"run_script {index}")
    return still_running


def test_the_state_read_right_after_a_motion_shows_its_program_ended(robot, home):
    assert programs_still_running_after_return(robot, home) == []


@simulator_only("an e-series controller's 500 Hz state stream")
def test_the_state_read_right_after_a_motion_shows_its_program_ended_on_an_e_series():
    with simulator_with(model="ur3e", initial_q=list(HOME)) as simulator, \
            ur3dq.robot.connect(simulator.host, heartbeat=False) as robot:
        assert programs_still_running_after_return(ready(robot), HOME) == []
