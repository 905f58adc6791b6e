"""SIGTERM and SIGHUP during `run-poses` are handled like Ctrl-C: stopj, one line, exit 128 + n.

Checked with ur_rtde.
"""
import signal
import time

import numpy as np
import pytest

from cli_support import cli_process, finish, run_poses_mid_move
from polling import wait_for
from robot_target import simulator_only

pytestmark = simulator_only("placing the arm by hand")

START = np.array([0.8, -1.0, 1.3, -1.9, -1.57, 0.5])
TARGET = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
SPEED = 0.15  # rad/s: the move takes ~5 s, so the signal surely lands mid-move
# stopj at 2 rad/s² from SPEED travels SPEED²/(2·2) ≈ 0.006 rad; the signal's own latency (a poll period) adds
# little. 0.05 rad is far below the 0.86 rad main travelled after a SIGTERM before this was handled.
TRAVEL_BOUND = 0.05


@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_polite_signal_mid_move_stops_the_arm(arm, run_cli, tmp_path, signum, code):
    with run_poses_mid_move(arm, run_cli, tmp_path, START, TARGET, SPEED) as process:
        at_signal = arm.joints()
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=20)
    assert process.returncode == code, stderr
    assert stderr.strip().splitlines()[-1] == (f"Error: interrupted by {signal.Signals(signum).name} (during move 1 "
                                                f"of 1, to 'target') — to go on: ur3dq --host {arm.host} run-poses "
                                                "--resume")
    deadline = time.monotonic() + 5
    while np.max(np.abs(arm.joint_speeds())) > 1e-6:  # the arm comes to rest by itself
        assert time.monotonic() < deadline, "the arm still moves after the signal"
        time.sleep(0.02)
    travel = np.max(np.abs(arm.joints() - at_signal))
    assert travel < TRAVEL_BOUND, f"the arm travelled {travel:.4f} rad after {signal.Signals(signum).name}"
    assert np.max(np.abs(arm.joints() - TARGET)) > 0.1, "the arm reached the target: the signal did not stop it"


def test_sigquit_mid_move_prints_every_threads_stack_and_the_run_goes_on(arm, run_cli, tmp_path):
    """SIGQUIT (Ctrl-\\) is how a user reports a hang: the stack of each thread, the motion left alone."""
    with run_poses_mid_move(arm, run_cli, tmp_path, START, TARGET, 0.5) as process:
        process.send_signal(signal.SIGQUIT)
        _, stderr = process.communicate(timeout=30)
    assert process.returncode == 0, stderr
    assert "Current thread" in stderr and "ur3dq/robot/" in stderr and 'File "' in stderr, stderr
    assert np.max(np.abs(arm.joints() - TARGET)) < 1e-3


def moving(arm):
    return np.max(np.abs(arm.joint_speeds())) > 0.02


def assert_the_rest_is_said(arm, stderr, code, process, during):
    """The report of a command stopped by SIGTERM mid-move: the step, where the arm rests (as run-poses says it),
    then the error line naming the signal."""
    assert process.returncode == code, stderr
    assert during in stderr, stderr
    assert wait_for(lambda: not moving(arm), timeout=5)
    rest = next(line for line in stderr.splitlines() if line.startswith("The arm is at rest at x "))
    x, y, z = (float(rest.split(f" {axis} ")[1].split()[0]) for axis in "xyz")
    np.testing.assert_allclose([x, y, z], arm.tcp_pose()[:3] * 1000, atol=0.1)
    assert stderr.strip().splitlines()[-1].startswith("Error: interrupted by SIGTERM"), stderr


def test_sigterm_during_move_to_says_where_the_arm_rests(arm, run_cli, tmp_path):
    arm.place(TARGET)
    assert run_cli("--host", arm.host, "record-pose", "--name", "far", "--yes").returncode == 0
    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "move-to", "far", "--yes", "--speed-scale", "0.1") as process:
        assert wait_for(lambda: moving(arm) or process.poll() is not None, timeout=20) and moving(arm)
        process.send_signal(signal.SIGTERM)
        _, stderr = finish(process)
    assert_the_rest_is_said(arm, stderr, 143, process, "Stopped during the move to 'far'.")


def test_sigterm_during_a_jog_step_says_where_the_arm_rests(arm, tmp_path):
    import subprocess

    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "jog", stdin=subprocess.PIPE) as process:
        process.stdin.write("s<1+")   # a 10° step of J1 at 10 % of the jog's speed: seconds long
        process.stdin.flush()
        assert wait_for(lambda: moving(arm) or process.poll() is not None, timeout=20) and moving(arm)
        process.send_signal(signal.SIGTERM)
        _, stderr = finish(process)
    assert_the_rest_is_said(arm, stderr, 143, process, "Stopped during the jog step J1+ by 10 °.")
