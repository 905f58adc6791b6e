"""Issue 14 items 5 and 6: `ur3dq robot ...` does what the pendant's buttons do (only when typed, refused where
the controller refuses), errors point at those commands, and a motion question defaults to No."""
import json

import numpy as np
import pytest

from cli_support import assert_one_line_error
from robot_target import simulator_only

pytestmark = simulator_only("powering the simulator off and on")


@pytest.fixture
def powered_off_sim():
    """A simulator process of its own, booted as a real controller boots: powered off, brakes held."""
    from sim_ursim.launch import simulator_process

    with simulator_process(model="ur3") as simulator:
        yield simulator.host


def mode(run_cli, host):
    result = run_cli("--host", host, "status", "--json")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)["robot_mode"]


def test_power_brakes_and_freedrive_from_the_command_line(powered_off_sim, run_cli, tmp_path):
    host = powered_off_sim
    assert mode(run_cli, host) == "POWER_OFF"
    # brakes of a powered-off arm: refused, pointing at power-on, and nothing is switched on by itself
    refused = run_cli("--host", host, "robot", "brake-release")
    assert_one_line_error(refused, 6, "brake release refused", "ur3dq robot power-on")
    assert mode(run_cli, host) == "POWER_OFF"

    result = run_cli("--host", host, "robot", "power-on")
    assert result.returncode == 0, result.stderr
    assert mode(run_cli, host) == "IDLE"
    result = run_cli("--host", host, "robot", "brake-release")
    assert result.returncode == 0, result.stderr
    assert mode(run_cli, host) == "RUNNING"

    result = run_cli("--host", host, "robot", "freedrive", "on", "--json")
    assert result.returncode == 0, result.stderr
    result = run_cli("--host", host, "robot", "freedrive", "off")
    assert result.returncode == 0 and "freedrive off" in result.stdout, result.stderr
    result = run_cli("--host", host, "robot", "stop")
    assert result.returncode == 0, result.stderr

    result = run_cli("--host", host, "robot", "power-off")
    assert result.returncode == 0, result.stderr
    assert mode(run_cli, host) == "POWER_OFF"


def test_a_motion_refused_for_the_robot_mode_names_the_commands_that_fix_it(powered_off_sim, run_cli, tmp_path):
    host = powered_off_sim
    result = run_cli("--host", host, "robot", "power-on")
    assert result.returncode == 0, result.stderr
    # record a pose (no motion needed), then try to replay it with the brakes still held
    result = run_cli("--host", host, "record-pose", "--name", "here", "--yes")
    assert result.returncode == 0, result.stderr
    result = run_cli("--host", host, "run-poses", "--yes", "--joints")
    assert_one_line_error(result, 6, "not RUNNING", "ur3dq robot power-on", "ur3dq robot brake-release")
    assert mode(run_cli, host) == "IDLE"  # never released automatically


def test_the_motion_question_defaults_to_no(arm, run_cli):
    place = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
    arm.place(place)
    result = run_cli("--host", arm.host, "record-pose", "--name", "there", "--yes")
    assert result.returncode == 0, result.stderr
    start = place + np.array([0.3, 0, 0, 0, 0, 0])
    arm.place(start)
    result = run_cli("--host", arm.host, "run-poses", input="\n")  # Enter alone at "Move the arm ...? [y/N]"
    assert result.returncode == 1, result.stderr
    assert "[y/N]" in result.stderr
    np.testing.assert_allclose(arm.joints(), start, atol=1e-9)
