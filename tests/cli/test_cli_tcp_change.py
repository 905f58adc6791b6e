"""Issue 14 item 4: a TCP offset changed since recording is announced before anything moves, the user chooses
(`--tcp recorded|current`), and the result says truthfully where the replay aimed the TCP."""
import json

import numpy as np
import pytest

import ur3dq.robot
from robot_target import simulator_only
from ur3dq.store import PoseStore

pytestmark = simulator_only("changing the simulator's TCP offset")

RECORDED_AT = np.array([0.0, -1.9, 2.0, -1.7, -1.57, 0.0])  # folded: reachable with the longer tool too
ELSEWHERE = np.array([0.3, -1.3, 1.1, -1.5, -1.4, 0.2])
NEW_TCP = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0]


@pytest.fixture
def arm_with_a_changed_tcp(run_cli, tmp_path):
    """(host, robot): a simulator of its own, one pose `p` recorded with TCP 0, then the TCP set 100 mm out along
    the flange's z and the arm moved elsewhere."""
    from sim_ursim.launch import simulator_process

    # The fixture places the arm with a connection of its own; the CLI under test moves it with its heartbeat, which
    # needs the RTDE inputs this connection would otherwise hold after its first motion.
    with simulator_process(model="ur3") as simulator, \
            ur3dq.robot.connect(simulator.host, backend="urx", heartbeat=False) as robot:
        robot.power_on()
        robot.brake_release()
        robot.movej(RECORDED_AT, a=3.0, v=2.0)
        result = run_cli("--host", simulator.host, "record-pose", "--name", "p", "--yes")
        assert result.returncode == 0, result.stderr
        robot.set_tcp(NEW_TCP)
        robot.movej(ELSEWHERE, a=3.0, v=2.0)
        yield simulator.host, robot


def test_a_changed_tcp_is_announced_and_nothing_moves_without_a_choice(arm_with_a_changed_tcp, run_cli):
    host, robot = arm_with_a_changed_tcp
    result = run_cli("--host", host, "run-poses", "--yes")
    assert result.returncode == 4, result.stderr
    assert "Warning: the controller's TCP offset" in result.stderr and "--tcp recorded" in result.stderr
    np.testing.assert_allclose(robot.joints(), ELSEWHERE, atol=1e-6)


def test_tcp_current_puts_the_current_tcp_on_the_recorded_pose(arm_with_a_changed_tcp, run_cli, tmp_path):
    host, robot = arm_with_a_changed_tcp
    result = run_cli("--host", host, "run-poses", "--yes", "--tcp", "current", "--json")
    assert result.returncode == 0, result.stderr
    reached = json.loads(result.stdout)["reached"][0]
    assert reached["target_from_recorded_m"] < 1e-6 and reached["error_m"] < 1e-4
    recorded = PoseStore(tmp_path / "poses.json").get("p")
    assert robot.tcp_pose().distance(recorded.dq)[0] < 1e-4


def test_tcp_recorded_puts_the_flange_back_and_the_table_says_so(arm_with_a_changed_tcp, run_cli, tmp_path):
    host, robot = arm_with_a_changed_tcp
    result = run_cli("--host", host, "run-poses", "--yes", "--tcp", "recorded")
    assert result.returncode == 0, result.stderr
    assert "recorded flange: 100.0 mm from the recorded TCP" in result.stdout
    np.testing.assert_allclose(robot.joints(), RECORDED_AT, atol=1e-4)


def test_a_cell_program_and_move_to_refuse_a_changed_tcp_without_a_choice(arm_with_a_changed_tcp, run_cli):
    host, robot = arm_with_a_changed_tcp
    assert run_cli("poses", "offset", "above", "--from", "p", "--z", "-0.03", "--before", "p").returncode == 0
    for args in (("run-poses", "--dry-run"), ("run-poses", "--yes"), ("move-to", "p", "--yes")):
        result = run_cli("--host", host, *args)
        assert result.returncode == 4, (args, result.stdout, result.stderr)
        assert "Warning: the controller's TCP offset" in result.stderr, (args, result.stderr)
        assert "--tcp recorded" in result.stderr.splitlines()[-1], (args, result.stderr)
        np.testing.assert_allclose(robot.joints(), ELSEWHERE, atol=1e-6)


def test_a_cell_program_honours_tcp_current_and_recorded(arm_with_a_changed_tcp, run_cli, tmp_path):
    host, robot = arm_with_a_changed_tcp
    assert run_cli("poses", "offset", "above", "--from", "p", "--z", "-0.03", "--before", "p").returncode == 0
    recorded = PoseStore(tmp_path / "poses.json").get("p")
    result = run_cli("--host", host, "run-poses", "--yes", "--tcp", "current")
    assert result.returncode == 0, result.stderr
    assert robot.tcp_pose().distance(recorded.dq)[0] < 1e-4   # the current (longer) TCP on the taught pose
    robot.movej(ELSEWHERE, a=3.0, v=2.0)
    result = run_cli("--host", host, "run-poses", "--yes", "--tcp", "recorded")
    assert result.returncode == 0, result.stderr
    np.testing.assert_allclose(robot.joints(), RECORDED_AT, atol=1e-4)   # the flange where it was taught


def test_move_to_honours_tcp_current_and_recorded(arm_with_a_changed_tcp, run_cli, tmp_path):
    host, robot = arm_with_a_changed_tcp
    recorded = PoseStore(tmp_path / "poses.json").get("p")
    result = run_cli("--host", host, "move-to", "p", "--yes", "--tcp", "current", "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["error_m"] < 1e-4
    assert robot.tcp_pose().distance(recorded.dq)[0] < 1e-4
    robot.movej(ELSEWHERE, a=3.0, v=2.0)
    result = run_cli("--host", host, "move-to", "p", "--yes", "--tcp", "recorded")
    assert result.returncode == 0, result.stderr
    assert "the TCP aimed 100.0 mm from the pose" in result.stdout and "is 0.000 mm" in result.stdout
    np.testing.assert_allclose(robot.joints(), RECORDED_AT, atol=1e-4)
