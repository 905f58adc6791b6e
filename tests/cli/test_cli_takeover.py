"""Another client on the same controller: it stops or replaces the program `run-poses` runs (the error names that
cause), or it runs a program of its own when `run-poses` starts (which asks, and refuses under --yes, instead of
replacing it silently)."""
import socket
import subprocess
import time

import numpy as np
import pytest

from cli_support import assert_one_line_error, finish, run_poses_mid_move
from polling import wait_for
from robot_target import simulator_only
from sim_ursim.control_channel import send_request

pytestmark = simulator_only("a second client sending to the simulator")

START = np.array([0.8, -1.0, 1.3, -1.9, -1.57, 0.5])
TARGET = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])
SPEED = 0.3


def send_to(host, port, text):
    """What another client does: `text` sent on `port` of the controller, the connection closed at once."""
    with socket.create_connection((host, port), timeout=5) as connection:
        if port == 29999:
            connection.recv(200)   # the dashboard's greeting
        connection.sendall(text.encode())
        if port == 29999:
            connection.recv(200)


def program_running(host):
    return send_request(host, "status")["state"]["program_running"]


@pytest.mark.parametrize("port, text, cause", [
    (30002, "def other():\n  sleep(2)\nend\n", "another client replaced it with its own program 'other'"),
    (29999, "stop\n", "stopped it without an error, as when another client stops the program"),
], ids=["replaced", "stopped"])
def test_a_run_taken_over_by_another_client_names_the_cause(arm, run_cli, tmp_path, port, text, cause):
    with run_poses_mid_move(arm, run_cli, tmp_path, START, TARGET, SPEED) as process:
        send_to(arm.host, port, text)
        stdout, stderr = finish(process)
    assert_one_line_error(subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr), 6, cause)
    assert wait_for(lambda: not program_running(arm.host), timeout=10)


def test_run_poses_does_not_replace_a_program_it_did_not_start(arm, run_cli, tmp_path):
    arm.place(TARGET)
    assert run_cli("--host", arm.host, "record-pose", "--name", "target", "--yes").returncode == 0
    arm.place(START)
    send_to(arm.host, 30002, "def other():\n  sleep(60)\nend\n")
    try:
        assert wait_for(lambda: program_running(arm.host), timeout=10)
        refused = run_cli("--host", arm.host, "run-poses", "--yes")
        assert_one_line_error(refused, 6, "another program is running on the controller (dashboard: PLAYING",
                              "nothing was sent", "stop it first")
        asked = run_cli("--host", arm.host, "run-poses", input="n\n")
        assert asked.returncode == 1 and "stop it and run this one instead? [y/N]" in asked.stderr, asked.stderr
        assert program_running(arm.host), "the other client's program was replaced"
        np.testing.assert_allclose(arm.joints(), START, atol=1e-6)
    finally:
        send_to(arm.host, 29999, "stop\n")
        time.sleep(0.2)
