"""python-urx 0.11, unmodified, against sim_ursim: what it can and cannot do per emulated version
(docs/urx-compatibility.md records the same facts)."""
import contextlib
import time

import numpy as np
import pytest
import urx
from urx.urrobot import RobotException

from polling import wait_for
from sim_ursim.launch import running_simulator

pytestmark = [
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),  # inside urx 0.11 itself
    # A urx reader thread that dies (its simulator stopped under it) fails the test instead of only warning.
    pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning"),
]

TARGET = [0.3, -1.2, 1.0, -1.4, -1.5, 0.2]
URX_READ_TIMEOUT = 5.0  # s, see connect()
FAST = dict(acc=3.0, vel=2.0)


@pytest.fixture
def urx_robots():
    """The urx robots a test opened; the simulator fixtures close them while the simulator still serves."""
    return []


@contextlib.contextmanager
def powered_simulator(urx_robots, **options):
    """A powered-up simulator that closes every urx robot in `urx_robots` before it stops: a urx monitor that
    outlives its peer raises TimeoutError in its reader thread (or spins on a closed socket and never joins)."""
    with running_simulator(model="ur3", **options) as simulator:
        simulator.controller.power_up()
        try:
            yield simulator
        finally:
            while urx_robots:
                close_urx(urx_robots.pop())


def close_urx(robot):
    """Close `robot`, its realtime monitor's thread included: URRobot.close() only flags that thread to stop, so it
    would read on after the simulator stopped, where its loop spins on the closed socket for the rest of the
    process. urx's own RealTimeMonitor.close() joins it: it sees its flag after the next packet of the 125 Hz
    stream."""
    robot.close()
    if robot.rtmon is not None:
        robot.rtmon.join(timeout=5)
        assert not robot.rtmon.is_alive(), "urx's realtime monitor did not end"


@pytest.fixture
def sim_3_15(urx_robots):
    with powered_simulator(urx_robots) as simulator:
        yield simulator


@pytest.fixture
def sim_3_4(urx_robots):
    with powered_simulator(urx_robots, version="3.4.5") as simulator:
        yield simulator


@pytest.fixture
def connect(urx_robots):
    def _connect(host, cls=urx.URRobot, **kwargs):
        robot = cls(host, **kwargs)
        urx_robots.append(robot)
        # urx reads 30002 with a 0.5 s timeout and its reader thread dies on the first one (no reconnect). On a
        # loaded 2-core box the 10 Hz stream of an in-process simulator has paused that long (the test then saw
        # frozen joints for 15 s), so the socket gets a 5 s timeout; urx's own code runs unmodified.
        robot.secmon._s_secondary.settimeout(URX_READ_TIMEOUT)
        return robot

    return _connect


def test_getj_and_getl_match_the_controller_on_the_default_3_15(sim_3_15, connect):
    sim_3_15.controller.movej(TARGET, a=3.0, v=2.0).wait(timeout=10)
    robot = connect(sim_3_15.host, cls=urx.Robot)
    state = sim_3_15.controller.state()
    assert robot.getj(wait=True) == pytest.approx(list(state.actual_q), abs=1e-12)
    # urx.Robot.getl needs math3d < 4 (PoseVector.tolist); the base class reads the same CartesianInfo.
    assert urx.URRobot.getl(robot) == pytest.approx(list(state.actual_tcp_pose), abs=1e-12)


def test_urx_0_11_does_not_recognise_the_real_3_15_robot_mode_layout(sim_3_15, connect):
    robot = connect(sim_3_15.host)
    assert robot.secmon._parser.version == (0, 0)
    assert robot.is_running() is False  # so movej(wait=True) cannot work here, see the next tests


def test_movej_without_waiting_moves_the_arm_on_3_15(sim_3_15, connect):
    robot = connect(sim_3_15.host)
    robot.movej(TARGET, wait=False, **FAST)
    assert wait_for(lambda: np.allclose(robot.getj(), TARGET, atol=1e-4), timeout=15)
    assert np.allclose(sim_3_15.controller.state().actual_q, TARGET, atol=1e-4)


def test_is_program_running_still_works_on_3_15(sim_3_15, connect):
    robot = connect(sim_3_15.host)
    robot.send_program("def waiting():\n  sleep(1.0)\nend")
    assert wait_for(robot.is_program_running, timeout=2)
    assert wait_for(lambda: not robot.is_program_running(), timeout=5)


def test_movej_with_waiting_is_refused_by_urx_on_3_15(sim_3_15, connect):
    robot = connect(sim_3_15.host)
    with pytest.raises(RobotException, match="Robot stopped"):
        robot.movej(TARGET, wait=True, **FAST)


@pytest.mark.parametrize("version, urx_sees", [("3.1.0", (3, 0)), ("3.4.5", (3, 2))])
def test_movej_with_waiting_returns_at_the_target_on_3_1_and_3_4(urx_robots, connect, version, urx_sees):
    with powered_simulator(urx_robots, version=version) as simulator:
        robot = connect(simulator.host)
        assert robot.secmon._parser.version == urx_sees and robot.is_running()
        started = time.monotonic()
        reached = robot.movej(TARGET, wait=True, **FAST)
        assert time.monotonic() - started > 0.5  # it really waited for the ~1.4 s move
        assert reached == pytest.approx(TARGET, abs=1e-3)
        assert not robot.is_program_running()


def test_is_program_running_follows_the_interpreter_on_3_4(sim_3_4, connect):
    robot = connect(sim_3_4.host)
    robot.send_program("def waiting():\n  sleep(1.0)\nend")
    assert wait_for(robot.is_program_running, timeout=2)
    assert sim_3_4.controller.state().runtime_state == 2
    assert wait_for(lambda: not robot.is_program_running(), timeout=5)


def test_movel_with_waiting_on_3_4(sim_3_4, connect):
    sim_3_4.controller.movej(TARGET, a=3.0, v=2.0).wait(timeout=10)
    robot = connect(sim_3_4.host)
    start = urx.URRobot.getl(robot, wait=True)
    goal = list(start)
    goal[2] += 0.05
    reached = robot.movel(goal, acc=1.0, vel=0.2, wait=True)
    assert reached == pytest.approx(goal, abs=2e-3)


def test_realtime_monitor_reads_joints_and_pose(sim_3_15, connect):
    sim_3_15.controller.movej(TARGET, a=3.0, v=2.0).wait(timeout=10)
    robot = connect(sim_3_15.host, use_rt=True)
    monitor = robot.get_realtime_monitor()
    assert wait_for(lambda: monitor.q_actual() is not None, timeout=2)
    state = sim_3_15.controller.state()
    assert list(monitor.q_actual(wait=True)) == pytest.approx(list(state.actual_q), abs=1e-12)
    assert list(monitor.q_target()) == pytest.approx(list(state.target_q), abs=1e-12)
    # urx's tcf_pose reads the realtime "tool vector target" field (doubles 73..78).
    assert list(monitor.tcf_pose()) == pytest.approx(list(state.target_tcp_pose), abs=1e-12)


def test_set_digital_out_sets_the_output_through_the_legacy_variable(sim_3_15, connect):
    """urx's set_digital_out sends `digital_out[n]=True`, the legacy I/O variable: the output goes on, then off."""
    robot = connect(sim_3_15.host)
    robot.set_digital_out(2, True)
    assert wait_for(lambda: sim_3_15.controller.state().standard_digital_output_bits & 0b100, timeout=5)
    robot.set_digital_out(2, False)
    assert wait_for(lambda: not sim_3_15.controller.state().standard_digital_output_bits & 0b100, timeout=5)
