"""kill -9 (or a hang) of `run-poses` mid-move: ur3dq can send no stopj, so the controller stops the arm by itself,
on the heartbeat its motion programs watch (ur3dq.robot.heartbeat). Checked from outside with the simulator's state."""
import os
import signal
import time

import numpy as np
import pytest

from cli_support import run_poses_mid_move
from processes import children_of
from robot_target import simulator_only
from ur3dq.robot.heartbeat import PERIOD, WATCHDOG_FREQUENCY

pytestmark = [simulator_only("placing the arm by hand"), pytest.mark.exclusive]

START = np.array([0.8, -1.0, 1.3, -1.9, -1.57, 0.5])
TARGET = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
SPEED = 0.15  # rad/s: the move takes ~5 s, so the kill surely lands mid-move
# The controller stops the program 1/WATCHDOG_FREQUENCY after the last heartbeat, at most one PERIOD before the kill;
# the simulator checks every 5 ms and the stop decelerates over ~0.01 rad. Without the heartbeat the arm runs on to
# the target, ~0.8 rad away.
DETECTION = 1.0 / WATCHDOG_FREQUENCY + PERIOD + 0.005
TRAVEL_BOUND = SPEED * DETECTION + 0.02
# From the kill to the arm at rest: the detection and the deceleration (well under 0.5 s from SPEED).
REST_BOUND = DETECTION + 0.5


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGSTOP], ids=["kill-9", "hung"])
def test_the_arm_stops_by_itself_when_run_poses_dies_mid_move(arm, run_cli, tmp_path, signum):
    with run_poses_mid_move(arm, run_cli, tmp_path, START, TARGET, SPEED) as process:
        at_kill, killed_at = arm.joints(), time.monotonic()
        process.send_signal(signum)
        while np.max(np.abs(arm.joint_speeds())) > 1e-6:  # the arm comes to rest by itself
            assert time.monotonic() - killed_at < 5, "the arm still moves after ur3dq died"
            time.sleep(0.005)
        rest_after = time.monotonic() - killed_at
        process.kill()   # a stopped (hung) process is ended here; a killed one is already gone
    travel = np.max(np.abs(arm.joints() - at_kill))
    assert travel < TRAVEL_BOUND, f"the arm travelled {travel:.4f} rad after ur3dq died"
    assert rest_after < REST_BOUND, f"the arm came to rest {rest_after:.2f} s after ur3dq died"
    assert np.max(np.abs(arm.joints() - TARGET)) > 0.1, "the arm reached the target: nothing stopped it"


def test_kill_9_during_teach_ends_freedrive_within_0_3_s(arm, tmp_path):
    """`record-pose --teach` holds freedrive with a program armed on the heartbeat like every motion: when ur3dq
    dies, the controller's watchdog stops that program and freedrive ends with it."""
    import subprocess

    from cli_support import cli_process
    from sim_ursim.control_channel import send_request

    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "record-pose", "--teach", stdin=subprocess.PIPE) as process:
        assert "Freedrive is on" in process.stderr.readline()
        assert send_request(arm.host, "status")["state"]["freedrive"]
        killed_at = time.monotonic()
        process.send_signal(signal.SIGKILL)
        while send_request(arm.host, "status")["state"]["freedrive"]:
            assert time.monotonic() - killed_at < 5, "freedrive is still on 5 s after ur3dq died"
            time.sleep(0.005)
        ended_after = time.monotonic() - killed_at
    assert ended_after < 0.3, f"freedrive ended {ended_after:.3f} s after ur3dq died"
    assert not send_request(arm.host, "status")["state"]["program_running"]


def ended(pid):
    """Whether process `pid` has ended (gone, or a zombie waiting for its new parent to reap it)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat_file:
            stat = stat_file.read()
    except OSError:
        return True
    return stat[stat.rfind(b")") + 2:][:1] == b"Z"


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads processes from /proc")
def test_the_heartbeat_process_ends_with_ur3dq(arm, tmp_path):
    """The heartbeat beats from a process of ur3dq's own, which must never outlive it: after kill -9 of ur3dq it
    reads the end of its pipe from ur3dq and exits. The kernel closes that pipe once it has freed ur3dq's memory,
    which a loaded machine takes tenths of a second to do; the beats stop before (the test above)."""
    import subprocess

    from cli_support import cli_process

    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "record-pose", "--teach", stdin=subprocess.PIPE) as process:
        assert "Freedrive is on" in process.stderr.readline()
        beating = children_of(process.pid)
        assert len(beating) == 1, f"ur3dq runs {len(beating)} processes, not its heartbeat's alone"
        killed_at = time.monotonic()
        process.send_signal(signal.SIGKILL)
        while not ended(beating[0]):
            assert time.monotonic() - killed_at < 5, "the heartbeat's process outlived ur3dq by 5 s"
            time.sleep(0.005)
        ended_after = time.monotonic() - killed_at
    assert ended_after < 3, f"the heartbeat's process ended {ended_after:.3f} s after ur3dq"
