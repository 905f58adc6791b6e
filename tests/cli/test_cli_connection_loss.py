"""A controller that drops every connection, or dies (SIGKILL), while `run-poses` moves the arm: ur3dq ends with exit
6 and one error line, every time. ur_rtde's RTDEIOInterface used to abort the process here (exit 134, `terminate
called after throwing ... write: Broken pipe`) once the error line was out; ur3dq's RTDE inputs are its own now."""
import signal
import subprocess
import time

import numpy as np
import pytest

from cli_support import UR3DQ, assert_one_line_error, cli_env
from powered_simulator import powered_simulator
from robot_target import simulator_only
from sim_ursim.control_channel import send_request
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

pytestmark = simulator_only("dropping the controller's connections and killing it")

RUNS = 10
START = (0.8, -1.0, 1.3, -1.9, -1.57, 0.5)
TARGET = (0.0, -1.2, 1.0, -1.4, -1.57, 0.0)
SPEED = "0.3"   # rad/s: the 0.8 rad move takes ~3 s, so the fault lands mid-move


@pytest.fixture
def store(tmp_path):
    """A store holding the pose at TARGET."""
    PoseStore(tmp_path / "poses.json").add(
        Pose.from_dual_quaternion("target", robot_model("ur3").fk(np.array(TARGET)), "ur3", joints=TARGET))
    return tmp_path / "poses.json"


def run_with_fault(tmp_path, host, fault):
    """`ur3dq run-poses` moving the arm at `host` from where it is to the stored target, `fault()` called once the
    arm moves; the finished process (text stderr)."""
    with subprocess.Popen([UR3DQ, "--host", host, "run-poses", "--yes", "--speed", SPEED], cwd=tmp_path,
                          env=cli_env(tmp_path), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True) as process:
        first = send_request(host, "status")["state"]["q"]
        deadline = time.monotonic() + 30
        while np.max(np.abs(np.subtract(send_request(host, "status")["state"]["q"], first))) < 0.02:
            assert process.poll() is None and time.monotonic() < deadline, process.communicate()
            time.sleep(0.02)
        fault()
        stdout, stderr = process.communicate(timeout=60)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


def test_dropped_connections_mid_move_end_in_exit_6(tmp_path, store):
    with powered_simulator(model="ur3", initial_q=START) as simulator:
        host = simulator.host
        for _ in range(RUNS):
            for command, arguments in (("freedrive", {"on": True}), ("move-by-hand", {"q": list(START)}),
                                       ("freedrive", {"on": False})):
                assert send_request(host, command, **arguments).get("ok")
            result = run_with_fault(tmp_path, host, lambda: send_request(host, "drop-connections"))
            assert "terminate called" not in result.stderr
            assert_one_line_error(result, 6, "closed")


def test_a_controller_killed_mid_move_ends_in_exit_6(tmp_path, store):
    for _ in range(RUNS):
        with powered_simulator(model="ur3", initial_q=START) as simulator:
            result = run_with_fault(tmp_path, simulator.host, lambda: simulator.process.send_signal(signal.SIGKILL))
        assert "terminate called" not in result.stderr
        assert_one_line_error(result, 6)
