"""The driver's jog (ur3dq.robot.jog) on a simulated arm: held, the arm moves only while its keep-alive comes and
stops when released; a step goes exactly its step; neither goes where the path check or a limit says no."""
import time

import numpy as np
import pytest

import ur3dq.robot
from polling import wait_for
from robot_test_support import HOME, ready, simulator_with
from ur3dq.errors import SafetyCheckError
from ur3dq.pathcheck import Box, Cell
from ur3dq.robot.jog import Jog
from ur3dq.robot.jog_steps import JogStep
from ur3dq.units import LENGTH


@pytest.fixture(scope="module")
def robot():
    with simulator_with(initial_q=list(HOME)) as simulator:
        with ur3dq.robot.connect(simulator.host) as connected:
            yield ready(connected)


@pytest.fixture
def at_home(robot):
    robot.movej(HOME)
    return robot


def at_rest(robot) -> bool:
    return float(np.max(np.abs(robot.state().joint_speeds))) < 1e-3


def hold(jog: Jog, seconds: float) -> None:
    """Keep the jog alive for `seconds`, as a page's heartbeat does (every 50 ms)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        jog.keep_alive()
        time.sleep(0.05)


def test_a_held_joint_jog_moves_one_joint_and_stops_on_release(at_home):
    jog = Jog(at_home)
    q0 = at_home.joints()
    jog.start(JogStep("J1", 1), speed=0.2)
    hold(jog, 0.5)
    released = at_home.joints()
    jog.stop()
    assert wait_for(lambda: at_rest(at_home), timeout=1.0)
    q1 = at_home.joints()
    assert released[0] - q0[0] > 0.05                                # 0.5 s at 0.2 rad/s, less the ramp
    assert np.allclose(q1[1:], q0[1:], atol=1e-9)                   # one joint only
    # its stop (0.002 rad at 10 rad/s²) and the stop program's way to the controller: 0.02 rad is 90 ms at 0.2 rad/s
    assert q1[0] - released[0] <= 0.02


def test_a_jog_whose_keep_alive_stops_is_stopped_by_the_controller(at_home):
    jog = Jog(at_home)
    q0 = at_home.joints()
    began = time.monotonic()
    jog.start(JogStep("J1", -1), speed=0.2)       # nobody keeps it alive after its start
    assert wait_for(lambda: abs(at_home.joints()[0] - q0[0]) > 0.005, timeout=1.0)
    assert wait_for(lambda: not at_home.state().program_running and at_rest(at_home), timeout=1.5)
    stopped_after = time.monotonic() - began
    assert stopped_after < 0.25 + 0.3, stopped_after                # the watchdog's 250 ms, its stop, polling
    assert abs(at_home.joints()[0] - q0[0]) < 0.2 * 0.6


def test_a_step_jog_goes_exactly_its_step(at_home):
    jog = Jog(at_home)
    q0 = at_home.joints()
    plan = jog.start(JogStep("J3", 1, 0.05), speed=0.3)
    assert plan.distance == 0.05 and plan.limited_by is None
    hold(jog, 0.6)
    assert wait_for(lambda: at_rest(at_home), timeout=1.0)
    assert at_home.joints()[2] - q0[2] == pytest.approx(0.05, abs=1e-4)


def test_a_linear_jog_moves_the_tcp_along_the_base_axis(at_home):
    jog = Jog(at_home)
    p0 = at_home.tcp_pose_vector()
    jog.start(JogStep("Z", -1, 0.02), speed=0.05)
    hold(jog, 0.8)
    assert wait_for(lambda: at_rest(at_home), timeout=1.0)
    moved = at_home.tcp_pose_vector() - p0
    assert moved[2] == pytest.approx(-0.02, abs=2e-4)
    assert np.allclose(moved[:2], 0.0, atol=2e-4) and np.allclose(moved[3:], 0.0, atol=1e-3)


def test_a_jog_towards_a_box_is_shortened_before_it_and_refused_at_it(at_home):
    tcp = at_home.tcp_pose_vector()[:3]
    wall = Box("wall", np.array([tcp[0] - 0.04, tcp[1] - 0.04, tcp[2] - 0.2]),
               np.array([tcp[0] + 0.04, tcp[1] + 0.04, tcp[2] - 0.12]))
    jog = Jog(at_home, Cell(boxes=(wall,), margin=0.01))
    plan = jog.plan(JogStep("Z", -1), 0.05)
    assert plan.limited_by == "the path check" and 0.0 < plan.distance < 0.15
    near = plan.joints
    with pytest.raises(SafetyCheckError, match="jog Z-: the arm cannot move that way") as refused:
        jog.plan(JogStep("Z", -1), 0.05, start=near)
    # its numbers are kept as values, which each screen shows in its own units
    assert any(value.kind is LENGTH for value in refused.value.measured), refused.value.measured
    assert 'keep-out box "wall" (margin 10 mm)' in str(refused.value)
    assert jog.plan(JogStep("Z", 1), 0.05, start=near).distance > 0.1   # away from it is free


def test_a_joint_jog_stops_short_of_its_limit(at_home):
    jog = Jog(at_home)
    start = at_home.joints().copy()
    start[1] = at_home.model.joint_upper[1] - 0.1
    plan = jog.plan(JogStep("J2", 1), 0.2, start=start)
    assert plan.limited_by == "the joint limit of J2"
    assert plan.joints[1] < at_home.model.joint_upper[1]
    with pytest.raises(SafetyCheckError, match="jog J2\\+: the arm cannot move that way: the joint limit of J2"):
        jog.plan(JogStep("J2", 1, 0.15), 0.2, start=start)            # a step is refused, never shortened


def test_robot_jog_is_checked_in_the_cell_the_robot_requires():
    with simulator_with(initial_q=list(HOME)) as simulator, ur3dq.robot.connect(simulator.host) as connected:
        robot = ready(connected)
        tcp = robot.tcp_pose_vector()[:3]
        wall = Box("wall", np.array([tcp[0] - 0.04, tcp[1] - 0.04, tcp[2] - 0.2]),
                   np.array([tcp[0] + 0.04, tcp[1] + 0.04, tcp[2] - 0.12]))
        robot.require_path_check(Cell(boxes=(wall,), margin=0.01))
        jog = Jog(robot)
        assert jog.cell is not None and jog.cell.boxes == (wall,)
        robot.movej(jog.plan(JogStep("Z", -1), 0.05).joints)         # as near the wall as a held jog goes
        before = robot.joints()
        with pytest.raises(SafetyCheckError, match='jog Z-: the arm cannot move that way: .*"wall"'):
            robot.jog(JogStep("Z", -1, 0.01), speed=0.05)
        assert np.allclose(robot.joints(), before, atol=1e-9)
        z = robot.tcp_pose_vector()[2]
        robot.jog(JogStep("Z", 1, 0.01), speed=0.05)                  # away from it
        assert robot.tcp_pose_vector()[2] - z == pytest.approx(0.01, abs=3e-4)


def test_a_held_jog_cannot_run_without_its_operator(robot):
    with pytest.raises(SafetyCheckError, match="a held jog needs its operator"):
        Jog(robot).run(JogStep("J1", 1), 0.1)
