"""Issue 14 items 5 and 6: `ur3dq robot ...` does what the pendant's buttons do (only when typed, refused where
the controller refuses), errors point at those commands, and a motion question defaults to No."""
import json
import subprocess

import numpy as np
import pytest

from cli_support import assert_one_line_error, cli_process, finish
from polling import wait_for
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

    result = run_cli("--host", host, "robot", "freedrive", "on", "--json", input="\n")   # Enter ends it
    assert result.returncode == 0 and json.loads(result.stdout)["action"] == "freedrive on, ended by enter", \
        result.stderr
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


def simulator_state(host):
    from sim_ursim.control_channel import send_request

    reply = send_request(host, "status")
    assert reply.get("ok"), reply
    return reply["state"]


def powered_and_released(run_cli, host):
    for action in ("power-on", "brake-release"):
        result = run_cli("--host", host, "robot", action)
        assert result.returncode == 0, result.stderr


def test_freedrive_on_holds_freedrive_until_enter_and_then_ends_it(powered_off_sim, run_cli, tmp_path):
    from sim_ursim.control_channel import send_request

    host = powered_off_sim
    powered_and_released(run_cli, host)
    pushed = [0.1, -1.2, 1.1, -1.5, -1.5, 0.2]
    with cli_process(tmp_path, "--host", host, "robot", "freedrive", "on", stdin=subprocess.PIPE) as process:
        assert "freedrive on: move the arm by hand" in process.stderr.readline()
        assert wait_for(lambda: simulator_state(host)["freedrive"], timeout=5)
        # the heartbeat's watchdog ended freedrive 0.16 s after the command returned: it must hold long after that
        with pytest.raises(subprocess.TimeoutExpired):
            process.wait(timeout=1.5)
        assert simulator_state(host)["freedrive"], "freedrive ended while the command held it"
        assert send_request(host, "move-by-hand", q=pushed).get("ok")   # the operator can hand-guide the arm
        process.stdin.write("\n")
        process.stdin.flush()
        out, err = finish(process)
    assert process.returncode == 0, err
    assert "freedrive off (Enter)" in out
    assert not simulator_state(host)["freedrive"]
    np.testing.assert_allclose(simulator_state(host)["q"], pushed, atol=1e-9)


def test_freedrive_off_from_another_shell_ends_the_held_freedrive(powered_off_sim, run_cli, tmp_path):
    host = powered_off_sim
    powered_and_released(run_cli, host)
    with cli_process(tmp_path, "--host", host, "robot", "freedrive", "on") as process:   # stdin at its end
        assert "freedrive on" in process.stderr.readline()
        assert wait_for(lambda: simulator_state(host)["freedrive"], timeout=5)
        assert process.poll() is None   # the end of stdin is not Enter
        result = run_cli("--host", host, "robot", "freedrive", "off")
        assert result.returncode == 0, result.stderr
        out, err = finish(process)
    assert process.returncode == 0, err
    assert "freedrive ended by something else" in out
    assert not simulator_state(host)["freedrive"]


def test_unlock_says_when_there_is_nothing_to_unlock_and_names_an_emergency_stop(powered_off_sim, run_cli):
    from sim_ursim.control_channel import send_request

    host = powered_off_sim
    powered_and_released(run_cli, host)
    result = run_cli("--host", host, "robot", "unlock")
    assert result.returncode == 0, result.stderr
    assert "no protective stop to unlock" in result.stdout and "unlocked" not in result.stdout
    assert send_request(host, "emergency-stop").get("ok")
    result = run_cli("--host", host, "robot", "unlock")
    assert_one_line_error(result, 6, "emergency-stopped", "release the e-stop")
    assert "unlocked" not in result.stdout


def test_a_jog_script_whose_steps_all_fail_exits_with_the_robot_fault_code(powered_off_sim, run_cli):
    host = powered_off_sim
    result = run_cli("--host", host, "jog", input="1+-q")
    assert "J1+ not moved" in result.stderr and "Jog ended." in result.stdout
    assert_one_line_error(result, 6, "2 jog steps of 2 did not move", "POWER_OFF")
