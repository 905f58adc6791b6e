"""What a controller must parse before it starts a program: the start timeout grows with the program's text, and a
program larger than a controller connection holds at once is refused before anything is sent."""
import numpy as np
import pytest

import ur3dq.robot
from polling import wait_for
from robot_target import simulator_only
from robot_test_support import HOME, ready, simulator_with
from ur3dq.errors import SafetyCheckError
from ur3dq.robot.motion import MAX_PROGRAM_LINES, START_TIMEOUT, program_start_timeout
from ur3dq.urscript import movej_statement

pytestmark = simulator_only("a program sized for the simulator's parser")

# Lines of list literals: slow to parse (sim_ursim takes seconds of CPU per MB of them), quick to run.
PADDING = "  x = [" + ", ".join(["1.25"] * 14) + "]\n"


@pytest.fixture(scope="module")
def robot():
    with simulator_with(initial_q=list(HOME)) as simulator, \
            ur3dq.robot.connect(simulator.host, backend="rtde") as connected:
        yield ready(connected)


def program_of(lines, target):
    """`def big(): ...` with `lines` padding lines, ending with a movej to `target`."""
    return "def big():\n" + PADDING * lines + f"  {movej_statement(target, a=1.4, v=1.05)}\nend\n"


@pytest.mark.exclusive   # a CPU-bound parse: 10-16 s alone, past its 32 s start timeout once beside the parallel pass
def test_a_program_that_takes_longer_than_the_base_timeout_to_parse_runs_to_its_end(robot):
    target = HOME + np.array([0.05, 0, 0, 0, 0, 0])
    program = program_of(30_000, target)   # 2.6 MB: well over START_TIMEOUT of parsing on any machine
    assert program_start_timeout(program) > START_TIMEOUT + 20
    robot.run_script("big", program, target, duration=0.5)
    np.testing.assert_allclose(robot.joints(), target, atol=1e-4)


def test_a_program_over_the_line_limit_is_refused_before_sending(robot):
    assert not robot.state().program_running   # the module's last program ended: run_script waited for the state
    program = "def big():\n" + "  x = 1\n" * MAX_PROGRAM_LINES + "end\n"
    with pytest.raises(SafetyCheckError, match=r"program big is too large to send: 50,003 lines \(the limit is "
                                               r"50,000\).*nothing was sent"):
        robot.run_script("big", program, HOME, duration=0.0)
    assert not wait_for(lambda: robot.state().program_running, timeout=0.5), "a program was sent"
