"""The heartbeat beats from a process of its own (ur3dq.robot.heartbeat_process): ur3dq's GIL held by one of its
threads (a C call, a parser) no longer stops a healthy motion, while ur3dq frozen for longer than HANG_TOLERANCE
still stops the arm. The GIL is held here by a pure-Python loop with the switch interval raised far above it, so
no other thread of the process runs meanwhile (a C call holding it for as long would do the same)."""
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import ur3dq.robot
from processes import children_of
from robot_target import simulator_only
from robot_test_support import HOME, ready, simulator_state, simulator_with
from ur3dq.errors import ProgramError
from ur3dq.robot.heartbeat import HANG_TOLERANCE, PERIOD, WATCHDOG_FREQUENCY
from ur3dq.robot.heartbeat_process import TICK_PERIOD

# Timing-sensitive (the arm's stop after a freeze of this process): run alone.
pytestmark = [simulator_only("reading the simulated arm while the driver is frozen"), pytest.mark.exclusive]

SPEED = 0.3   # rad/s
MOVE = np.array([1.2, 0, 0, 0, 0, 0])   # ~4.3 s at SPEED: the freeze lands mid-move


@pytest.fixture
def moving_robot():
    """(simulator host, Robot at HOME, with its heartbeat) on a simulator process of its own."""
    with simulator_with(initial_q=list(HOME)) as simulator, ur3dq.robot.connect(simulator.host) as robot:
        yield simulator.host, ready(robot)


def hold_the_gil(seconds):
    """Keep every other thread of this process from running for `seconds` (wall clock), as a C call holding the GIL
    does: a pure-Python loop that the interpreter never asks to give the GIL up, with the switch interval above it."""
    before = sys.getswitchinterval()
    sys.setswitchinterval(seconds * 10)
    try:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            pass
    finally:
        sys.setswitchinterval(before)


class FreezeMidMove(threading.Thread):
    """Once the simulator at `host` shows the program running and J1 0.05 rad from HOME, hold the GIL for `seconds`;
    `joints_at_freeze`: the simulator's joints just before."""

    def __init__(self, host, seconds):
        super().__init__(daemon=True)
        self.host, self.seconds, self.joints_at_freeze = host, seconds, None

    def run(self):
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            state = simulator_state(self.host)
            if state["program_running"] and abs(state["q"][0] - HOME[0]) > 0.05:
                self.joints_at_freeze = np.array(state["q"])
                hold_the_gil(self.seconds)
                return
            time.sleep(0.01)


def heartbeat_processes():
    """Pids of this process's children that run the heartbeat."""
    def command(pid):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
                return cmdline.read()
        except OSError:   # it ended meanwhile
            return b""
    return [pid for pid in children_of(os.getpid()) if b"heartbeat_process" in command(pid)]


def real_time_allowed():
    """Whether a process of this user may take SCHED_FIFO priority 1."""
    probe = "import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))"
    return subprocess.run([sys.executable, "-c", probe], capture_output=True).returncode == 0


def test_the_beats_run_at_real_time_priority_where_the_user_may(moving_robot):
    _, robot = moving_robot
    robot.movej(HOME + [0.05, 0, 0, 0, 0, 0], a=1.4, v=1.0)
    expected = os.SCHED_FIFO if real_time_allowed() else os.SCHED_OTHER
    assert [os.sched_getscheduler(pid) for pid in heartbeat_processes()] == [expected]


def test_a_gil_held_for_0_3_s_does_not_stop_the_motion(moving_robot):
    host, robot = moving_robot
    freeze = FreezeMidMove(host, 0.3)
    freeze.start()
    robot.movej(HOME + MOVE, v=SPEED)   # a ProgramError naming the heartbeat watchdog when the beats wait for the GIL
    freeze.join(5)
    assert freeze.joints_at_freeze is not None, "the motion was never seen running"
    assert np.allclose(robot.joints(), HOME + MOVE, atol=1e-3)


def test_a_driver_frozen_longer_than_the_hang_tolerance_stops_the_arm(moving_robot):
    host, robot = moving_robot
    freeze = FreezeMidMove(host, HANG_TOLERANCE + 1.5)
    freeze.start()
    with pytest.raises(ProgramError, match="heartbeat watchdog"):
        robot.movej(HOME + MOVE, v=SPEED)
    freeze.join(5)
    assert freeze.joints_at_freeze is not None, "the motion was never seen running"
    # The beats stop a tolerance after the last tick; the watchdog stops the program a period after the last beat;
    # then the arm decelerates (well under 0.05 rad from SPEED). Unstopped, it would travel SPEED × 2.5 s = 0.75 rad.
    detection = TICK_PERIOD + HANG_TOLERANCE + PERIOD + 1.0 / WATCHDOG_FREQUENCY
    travel = np.max(np.abs(np.array(simulator_state(host)["q"]) - freeze.joints_at_freeze))
    assert travel < SPEED * (detection + 0.1) + 0.05, f"the arm travelled {travel:.3f} rad after the freeze began"
