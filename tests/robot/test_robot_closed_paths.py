"""Issue 14 item 1: a motion is done only after evidence that *this* program ran and ended, even when the arm
starts at rest on its target (closed paths, zero-length moves, paths that revisit their start).

The arm cannot travel a movej path faster than its trapezoids, so a call that returns before the controller's
clock has advanced by the sum of their durations returned while the arm was still moving (or before it had
left): that is what is asserted, on every one of 50+ calls against a simulator process of its own, for each
backend. The controller's clock, not this process's: a simulator held back by a loaded machine computes its late
cycles back to back when it catches up, so a motion may take less wall time than it takes on the controller.
"""
import numpy as np
import pytest

from robot_test_support import HOME
from sim_ursim.control_channel import send_request
from ur3dq.robot import motion, state

A = HOME
B = HOME + np.array([0.06, -0.04, 0.05, 0.0, 0.03, 0.05])
ACCELERATION, SPEED = 2.0, 1.0  # below the UR3's limits: the driver does not lower them
PATHS = (
    ("closed [B, A]", [B, A]),
    ("revisits its start [A, B, A]", [A, B, A]),
    ("zero-length [A, A]", [A, A]),
    ("closed twice [B, A, B, A]", [B, A, B, A]),
)
RUNS = 52


@pytest.mark.timeout(300)
def test_no_path_call_returns_before_its_program_ran_and_ended(own_sim_robot):
    host, robot = own_sim_robot
    early = []
    for run in range(RUNS):
        label, targets = PATHS[run % len(PATHS)]
        sent_after = controller_time(host)
        robot.movej_path(targets, a=ACCELERATION, v=SPEED)
        seconds = controller_time(host) - sent_after
        shortest = motion.path_duration(A, targets, ACCELERATION, SPEED)
        if seconds < shortest * 0.98:
            early.append(f"run {run} {label}: returned after {seconds:.3f} s of the controller's time, the path "
                         f"takes ≥ {shortest:.3f} s")
        status = robot.state()
        assert state.at_rest_at(status, A), f"run {run} {label}: not at rest at A after returning"
    assert not early, "; ".join(early)


def controller_time(host):
    """The simulated controller's clock (s), as its RTDE `timestamp` counts it."""
    reply = send_request(host, "status")
    assert reply["ok"], reply
    return reply["state"]["time"]


def test_a_single_zero_length_move_sends_nothing_and_returns_at_once(own_sim_robot):
    _, robot = own_sim_robot
    assert robot.movej(A) == 0.0
