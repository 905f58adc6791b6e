"""The stop report after the controller's streams froze mid-program names the step from the controller's own reports.

A freeze hides the program's step reports and state for as long as it lasts; ur3dq stops the program once the state
is a second old, and the arm may have gone on to a later step meanwhile. The reports and the state arrive late, not
never: the report must name the step they show and where the arm came to rest, not the last ones seen before the
freeze.
"""
import subprocess
import time

import numpy as np

from cli_support import assert_one_line_error, cli_process, finish
from powered_simulator import powered_simulator
from robot_target import simulator_only
from sim_ursim.control_channel import send_request
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, Wait, Waypoint
from ur3dq.store import PoseStore

pytestmark = simulator_only("freezing the simulator's streams")

MODEL = robot_model("ur3")
START = np.array([0.1, -1.4, 1.5, -1.7, -1.5708, 0.0])
Q_APPROACH = np.array([0.3, -1.3, 1.4, -1.7, -1.5708, 0.2])
Q_PLACE = np.array([0.8, -1.2, 1.3, -1.7, -1.5708, 0.6])
FAST = Motion("joint", 2.0, 4.0)   # the approach takes about 0.45 s
# s: longer than ur_rtde's 2.5 s read deadline twice over after the 1 s freeze check and the 3 s wait for late
# reports, so the RTDE session ur3dq reopens for its stop report dies too before the controller speaks again
LONG_FREEZE = 8.0
ENDLESS_FREEZE = 20.0   # s: well past the bound on run-poses' end once a stream froze (docs/architecture.md)


def write_program(path):
    """approach (a joint move), settle (a 3 s wait), place (a joint move)."""
    def waypoint(name, q):
        return Waypoint(name, Pose.from_dual_quaternion(name, MODEL.fk(q), "ur3", joints=tuple(q)), FAST)

    steps = [waypoint("approach", Q_APPROACH), Wait("settle", 3.0), waypoint("place", Q_PLACE)]
    PoseStore(path).update_program(lambda old: (steps, None))


def wait_until_the_arm_moves(host, process):
    """Wait (60 s at most, while `process` runs) until the simulated arm has left START: freeze it now and it freezes
    0.1 s into the approach."""
    deadline = time.monotonic() + 60
    while np.max(np.abs(np.array(send_request(host, "status")["state"]["q"]) - START)) < 0.01:
        assert time.monotonic() < deadline and process.poll() is None, "the arm never moved"
        time.sleep(0.005)


def test_a_freeze_during_a_move_is_reported_at_the_step_and_place_the_arm_reached(tmp_path):
    """Frozen 0.1 s into the approach for 2 s: ur3dq stops the program about 1 s later, during the wait, with the
    arm on the approach's target; the report names the wait and that place (the last report before the freeze named
    the approach, and the last state showed the arm moving)."""
    write_program(tmp_path / "poses.json")
    with powered_simulator(model="ur3", initial_q=list(START)) as simulator:
        host = simulator.host
        with cli_process(tmp_path, "--host", host, "run-poses", "--yes") as process:
            wait_until_the_arm_moves(host, process)
            assert send_request(host, "freeze", seconds=2.0)["ok"]
            _, stderr = process.communicate(timeout=60)
        rest = np.array(send_request(host, "status")["state"]["q"])
    assert process.returncode == 6, stderr
    assert np.max(np.abs(rest - Q_APPROACH)) < 1e-3, "the program was not stopped during the wait"
    assert "Stopped during step 2 of 3, 'settle' (wait)." in stderr, stderr
    assert "The arm is at rest at " in stderr, stderr
    x, y, z = MODEL.fk(Q_APPROACH).translation * 1000
    assert f"x {x:.1f} y {y:.1f} z {z:.1f} mm" in stderr, stderr


def test_a_long_freeze_ends_the_run_and_the_arm_stays_stopped(tmp_path):
    """Frozen 0.1 s into the approach for 8 s: ur_rtde ends its RTDE session after 2.5 s without data, and so does
    the one ur3dq opens again to read where the arm rests. run-poses still ends, with exit 6 and one error line
    naming the frozen stream and the command that goes on, the store untouched; once the freeze is over the arm
    rests where the controller's watchdog stopped it (on the approach's target, during the wait), no program
    running, and it stays there."""
    store = tmp_path / "poses.json"
    write_program(store)
    kept = store.read_bytes()
    with powered_simulator(model="ur3", initial_q=list(START)) as simulator:
        host = simulator.host
        with cli_process(tmp_path, "--host", host, "run-poses", "--yes") as process:
            wait_until_the_arm_moves(host, process)
            thawed_at = time.monotonic() + LONG_FREEZE
            assert send_request(host, "freeze", seconds=LONG_FREEZE)["ok"]
            stdout, stderr = finish(process)
        after = []
        for wait in (max(0.0, thawed_at - time.monotonic()) + 0.5, 1.0):   # after the freeze, then a second later
            time.sleep(wait)
            after.append(send_request(host, "status")["state"])
    assert_one_line_error(subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr), 6,
                          "froze", "run-poses --resume")
    assert store.read_bytes() == kept
    assert not any(state["program_running"] for state in after), after
    for state in after:
        assert np.max(np.abs(np.array(state["q"]) - Q_APPROACH)) < 1e-3, "the arm moved on after the freeze"


def test_run_poses_ends_while_the_controller_is_still_frozen(tmp_path):
    """However long the controller stays silent, run-poses ends within a bound (the 1 s freeze check, 3 s for late
    reports, one reconnection attempt for the stop report): here before a 20 s freeze is over, saying where the arm
    is could not be read. Once the freeze is cleared the arm is stopped and stays so."""
    write_program(tmp_path / "poses.json")
    with powered_simulator(model="ur3", initial_q=list(START)) as simulator:
        host = simulator.host
        with cli_process(tmp_path, "--host", host, "run-poses", "--yes") as process:
            wait_until_the_arm_moves(host, process)
            thawed_at = time.monotonic() + ENDLESS_FREEZE
            assert send_request(host, "freeze", seconds=ENDLESS_FREEZE)["ok"]
            _, stderr = process.communicate(timeout=ENDLESS_FREEZE + 30)
        ended_at = time.monotonic()
        assert send_request(host, "reset")["ok"]
        time.sleep(0.5)
        rest = send_request(host, "status")["state"]
        time.sleep(1.0)
        later = send_request(host, "status")["state"]
    assert ended_at < thawed_at, f"run-poses ended {ended_at - thawed_at:.1f} s after the freeze, not during it"
    assert process.returncode == 6, stderr
    assert "Where the arm is could not be read" in stderr, stderr
    assert not rest["program_running"] and rest["q"] == later["q"], (rest, later)


def test_a_stale_last_state_is_reported_as_such():
    """When no fresh state came before the report (the stream still silent), the report says how old the last state
    received is and that the arm may have moved since, instead of calling that place where it rests."""
    from ur3dq.cli.run_session import where_text
    from ur3dq.program.runner import ProgramStop

    q = Q_APPROACH
    pose = np.concatenate([MODEL.fk(q).translation, np.zeros(3)])
    fresh = ProgramStop(1, "approach", q, pose, (), False)
    stale = ProgramStop(1, "approach", q, pose, (), False, stale_for=3.2)
    assert where_text(fresh, deg=False).startswith("The arm is at rest at x ")
    text = where_text(stale, deg=False)
    assert text.startswith("The last state received (3.2 s old: the arm may have moved since) showed x ")
    assert "at rest" not in text
