"""`python -m sim_ursim` / `sim-ursim` as a person runs them: a real subprocess, real clients, the fault command."""
import json
import os
import socket
import subprocess
import sys
import time

import dashboard_client
import pytest
from click.testing import CliRunner

from sim_ursim.__main__ import main, parse_joint_list
from sim_ursim.control_channel import send_request
from sim_ursim.launch import free_loopback_address, simulator_process


def cli(*arguments, timeout=30):
    """Run `python -m sim_ursim ARGUMENTS` to completion."""
    return subprocess.run([sys.executable, "-m", "sim_ursim", *arguments], capture_output=True, text=True,
                          timeout=timeout)


def test_simulator_process_serves_dashboard_and_takes_faults_from_the_command_line(tmp_path):
    log_path = tmp_path / "sim.log"
    with simulator_process(model="ur3e", initial_q=[0.1, -1.2, 1.2, -1.5, -1.5, 0], log_path=str(log_path)) as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        try:
            assert client.polyscopeVersion() == "5.11.1.108318"
            client.brakeRelease()
            deadline = time.monotonic() + 10
            while client.robotmode() != "Robotmode: RUNNING" and time.monotonic() < deadline:
                time.sleep(0.05)
            result = cli("fault", "protective-stop", "--host", sim.host, "--reason", "cli test")
            assert (result.returncode, result.stdout) == (0, "protective stop\n")
            assert client.safetymode() == "Safetymode: PROTECTIVE_STOP"
            status = cli("fault", "status", "--host", sim.host).stdout
            assert "safety PROTECTIVE_STOP" in status and "q [+0.1000 -1.2000 +1.2000" in status
            frozen = cli("fault", "freeze", "--host", sim.host)
            assert frozen.returncode == 2 and "freeze needs --seconds" in frozen.stderr
        finally:
            client.disconnect()
        process = sim.process
    assert process.returncode == 0  # SIGTERM is a clean stop
    log = log_path.read_text()
    for line in ("serving on " + sim.host, "robot mode POWER_OFF -> POWER_ON", "protective stop: cli test",
                 "'PolyscopeVersion' -> 'URSoftware 5.11.1.108318 (Dec 08 2021)'", "stopped"):
        assert line in log


def test_dashboard_shutdown_ends_the_process():
    with simulator_process() as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        client.shutdown()
        assert sim.process.wait(timeout=10) == 0


def test_hand_guiding_command_moves_the_arm():
    with simulator_process() as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        client.brakeRelease()
        deadline = time.monotonic() + 10
        while client.robotmode() != "Robotmode: RUNNING" and time.monotonic() < deadline:
            time.sleep(0.05)
        client.disconnect()
        result = cli("move-by-hand", "0.2,-1,1,-1.5,-1.5,0.3", "--host", sim.host)
        assert result.returncode == 0, result.stderr
        status = send_request(sim.host, "status")
        assert "q [+0.2000 -1.0000 +1.0000 -1.5000 -1.5000 +0.3000]" in status["message"]   # for people
        assert status["state"]["q"] == pytest.approx([0.2, -1, 1, -1.5, -1.5, 0.3], abs=1e-9)  # for programs
        assert status["state"]["robot_mode"] == "RUNNING" and status["state"]["program_running"] is False


def test_hand_guiding_takes_negative_joints_and_the_host_from_the_environment_and_keeps_a_teach_freedrive():
    """`move-by-hand -0.2 -1 ...` needs no `--`; UR3DQ_HOST (ur3dq's own address variable) names the simulator;
    when a program holds freedrive (`record-pose --teach`), pushing the arm leaves it on."""
    with simulator_process() as sim:
        client = dashboard_client.DashboardClient(sim.host)
        client.connect()
        client.brakeRelease()
        deadline = time.monotonic() + 10
        while client.robotmode() != "Robotmode: RUNNING" and time.monotonic() < deadline:
            time.sleep(0.05)
        client.disconnect()
        environment = {**os.environ, "UR3DQ_HOST": sim.host}
        environment.pop("SIM_URSIM_HOST", None)
        pushed = subprocess.run([sys.executable, "-m", "sim_ursim", "move-by-hand", "-0.2", "-1", "1", "-1.5",
                                 "-1.5", "0.3"], capture_output=True, text=True, timeout=30, env=environment)
        assert pushed.returncode == 0, pushed.stderr
        assert send_request(sim.host, "status")["state"]["q"] == pytest.approx([-0.2, -1, 1, -1.5, -1.5, 0.3])
        with socket.create_connection((sim.host, 30001)) as primary:   # a teach program, as record-pose sends it
            primary.sendall(b"def teach():\n  freedrive_mode()\n  sleep(60)\nend\n")
            deadline = time.monotonic() + 5
            while not send_request(sim.host, "status")["state"]["freedrive"]:
                assert time.monotonic() < deadline, "freedrive never came on"
                time.sleep(0.02)
            again = subprocess.run([sys.executable, "-m", "sim_ursim", "move-by-hand", "-0.1,-1,1,-1.5,-1.5,0.3"],
                                   capture_output=True, text=True, timeout=30, env=environment)
        assert again.returncode == 0 and "freedrive stays on" in again.stdout, again.stderr
        status = send_request(sim.host, "status")["state"]
        assert status["freedrive"] and status["program_running"] and status["q"][0] == pytest.approx(-0.1)


def test_fault_shutdown_ends_the_process():
    with simulator_process() as sim:
        result = cli("fault", "shutdown", "--host", sim.host)
        assert (result.returncode, result.stdout) == (0, "shutting down\n")
        assert sim.process.wait(timeout=10) == 0


def test_fault_without_a_simulator_says_so():
    result = cli("fault", "emergency-stop", "--host", free_loopback_address())
    assert result.returncode == 1 and "no simulator control channel on" in result.stderr
    assert "Pass --host ADDRESS (or export UR3DQ_HOST)" in result.stderr
    moved = cli("move-by-hand", "0", "0", "0", "0", "0", "0", "--host", free_loopback_address())
    assert moved.returncode == 1 and "Pass --host ADDRESS" in moved.stderr


@pytest.mark.parametrize("arguments, message", [
    (["--initial-q", "1,2,3"], "joints must be 6 numbers"),
    (["--model", "ur4"], "Invalid value for '--model'"),
    (["--version", "5.11.1"], "does not fit model ur3"),
    (["--initial-q", "7,0,0,0,0,0"], "initial_q: joint 0 at 7.0000 rad is outside its limits"),
])
def test_bad_options_are_refused_with_a_clear_message(arguments, message):
    result = CliRunner().invoke(main, ["--host", free_loopback_address(), *arguments])
    assert result.exit_code == 2 and message in result.output


def test_bad_calibration_file_is_refused(tmp_path):
    calibration = tmp_path / "cal.json"
    calibration.write_text(json.dumps({"a": [0, 0.001]}))
    result = CliRunner().invoke(main, ["--host", free_loopback_address(), "--calibration", str(calibration)])
    assert result.exit_code == 2 and "calibration['a'] must be 6 finite numbers" in result.output


def test_parse_joint_list_accepts_commas_and_spaces():
    assert parse_joint_list("0, -1.5 2 0 0 0.25") == [0, -1.5, 2, 0, 0, 0.25]
