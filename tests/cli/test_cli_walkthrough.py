"""What a new user meets doing the pick-and-place job from `ur3dq --help` alone: every dead end names the way on."""
import json
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cli_support import cli_env, cli_process, finish
from polling import wait_for
from robot_target import simulator_only

pytestmark = simulator_only("pushing the simulated arm by hand")

PLACE = np.array([0.0, -1.2, 1.0, -1.4, -1.57, 0.0])


@pytest.fixture(scope="module")
def simulator():
    """A powered simulator process of this module, at PLACE."""
    from cli_support import SimulatedArm
    from powered_simulator import powered_simulator

    with powered_simulator(model="ur3") as running:
        arm = SimulatedArm(running.host)
        arm.place(PLACE)
        try:
            yield running, arm
        finally:
            arm.receive.disconnect()


def as_sim_start_left_it(tmp_path, simulator):
    """The state file `ur3dq sim start` writes, naming this simulator process: ur3dq then treats it as its own."""
    state = tmp_path / "state"
    state.mkdir(exist_ok=True)
    (state / "sim.json").write_text(json.dumps({"pid": simulator.process.pid, "host": simulator.host,
                                                "model": "ur3", "version": None, "log": "", "started": ""}))


def test_teach_on_our_simulator_prints_the_hand_that_moves_it(simulator, tmp_path):
    running, arm = simulator
    as_sim_start_left_it(tmp_path, running)
    with cli_process(tmp_path, "record-pose", "--teach", "--name", "t", stdin=subprocess.PIPE) as process:
        assert "Freedrive is on" in process.stderr.readline()
        assert "be the hand from another terminal" in process.stderr.readline()
        lines = [process.stderr.readline(), process.stderr.readline()]   # one command on two lines of < 80
        assert all(len(line.rstrip("\n")) <= 80 for line in lines), lines
        command = shlex.split("".join(lines).replace("\\\n", " "))   # a shell joins the continued line
        assert command[:4] == ["sim-ursim", "move-by-hand", "--host", running.host], command
        np.testing.assert_allclose([float(value) for value in command[4:]], PLACE, atol=0.006)
        target = PLACE + [0.3, 0.0, 0.0, 0.0, 0.0, 0.0]
        pushed = subprocess.run([str(Path(sys.executable).with_name("sim-ursim")), *command[1:4], *map(str, target)],
                                env=cli_env(tmp_path), capture_output=True, text=True, timeout=30)
        assert pushed.returncode == 0, pushed.stderr
        assert wait_for(lambda: np.max(np.abs(arm.joints() - target)) < 1e-6, timeout=5)
        process.stdin.write("\nq\n")
        process.stdin.flush()
        stdout, stderr = process.communicate(timeout=20)
    assert process.returncode == 0, stderr
    assert "Recorded 1 pose" in stdout


def test_teach_on_another_controller_prints_no_simulator_hand(simulator, tmp_path):
    running, _ = simulator
    with cli_process(tmp_path, "--host", running.host, "record-pose", "--teach", stdin=subprocess.PIPE) as process:
        process.stdin.write("q\n")
        process.stdin.flush()
        _, stderr = process.communicate(timeout=20)
    assert process.returncode == 0, stderr
    assert "Freedrive is on" in stderr and "move-by-hand" not in stderr


def test_jog_beside_a_teach_session_names_the_command_to_end(simulator, tmp_path):
    running, _ = simulator
    with cli_process(tmp_path, "--host", running.host, "record-pose", "--teach", stdin=subprocess.PIPE) as teach:
        assert "Freedrive is on" in teach.stderr.readline()
        jog = subprocess.run([str(Path(sys.executable).with_name("ur3dq")), "--host", running.host, "jog"],
                             input="+q", env=cli_env(tmp_path), cwd=tmp_path, capture_output=True, text=True,
                             timeout=60)
        teach.stdin.write("q\n")
        teach.stdin.flush()
        teach.communicate(timeout=20)
    assert "J1+ not moved" in jog.stderr and "end the other ur3dq command" in jog.stderr, jog.stderr


def screen_lines_after(terminal, fragment, timeout=60):
    """Every line the terminal showed after `fragment` until its process ended (a redrawn line: each drawing)."""
    terminal.wait_for(fragment, timeout)
    terminal.process.wait(timeout)
    time.sleep(0.2)   # the last output read
    return [part for line in terminal.text.split("\n") for part in line.split("\r")]


def test_the_stop_report_and_the_resume_fit_80_columns(simulator, tmp_path):
    from cli_support import Terminal
    from ur3dq.kinematics import robot_model
    from ur3dq.pose import Pose
    from ur3dq.program.steps import DigitalOut, Motion, Waypoint
    from ur3dq.store import PoseStore

    running, arm = simulator
    arm.place(PLACE)
    ur3, far = robot_model("ur3"), PLACE + [1.2, 0.0, 0.0, 0.0, 0.0, 0.0]
    steps = [DigitalOut("grip", "tool", 0, True),
             Waypoint("far", Pose.from_dual_quaternion("far", ur3.fk(far), "ur3", joints=tuple(far)),
                      Motion("joint", 0.2))]
    PoseStore(tmp_path / "poses.json").update_program(lambda old: (steps, None))
    terminal = Terminal(tmp_path, "--host", running.host, "run-poses", "--yes")
    try:
        terminal.wait_for("p pauses, s stops, q quits")
        assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) > 0.05, timeout=20)
        terminal.process.send_signal(signal.SIGINT)   # Ctrl-C (this pty is not the process's controlling tty)
        lines = screen_lines_after(terminal, "Stopped during")
    finally:
        terminal.close()
    assert terminal.process.returncode == 130, "\n".join(lines)
    assert any(line.startswith("Error: interrupted") for line in lines), lines
    assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]
    terminal = Terminal(tmp_path, "--host", running.host, "run-poses", "--resume", "--yes")
    try:
        lines = screen_lines_after(terminal, "Resuming at")
    finally:
        terminal.close()
    assert terminal.process.returncode == 0, lines
    assert all(len(line) <= 80 for line in lines), [line for line in lines if len(line) > 80]


def test_teach_names_a_late_heartbeat_when_freedrive_ends_with_the_watchdog(simulator, tmp_path):
    from sim_ursim.control_channel import send_request

    running, _ = simulator
    freedrive = lambda: send_request(running.host, "status")["state"]["freedrive"]   # noqa: E731
    with cli_process(tmp_path, "--host", running.host, "record-pose", "--teach", stdin=subprocess.PIPE) as process:
        assert "Freedrive is on" in process.stderr.readline()
        assert wait_for(freedrive, timeout=10)
        process.send_signal(signal.SIGSTOP)   # a computer too busy to run ur3dq: its heartbeat stops
        try:
            assert wait_for(lambda: not freedrive(), timeout=10)   # the controller's watchdog ended the program
        finally:
            process.send_signal(signal.SIGCONT)
        time.sleep(1.0)   # its state stream catches up (a person's Enter never comes at once after a stall)
        process.stdin.write("\n")
        process.stdin.flush()
        line = process.stderr.readline()
        process.stdin.write("q\n")
        process.stdin.flush()
        process.communicate(timeout=20)
    assert "not recorded: freedrive ended" in line and "watchdog stopped it: ur3dq's heartbeat came late" in line, line
    assert "f then Enter switches it on again" in line


def test_a_jog_step_stopped_short_says_the_key_again_goes_on(simulator, tmp_path):
    running, arm = simulator
    arm.place(PLACE)
    with cli_process(tmp_path, "--host", running.host, "jog", stdin=subprocess.PIPE) as process:
        process.stdin.write("s<+")   # 10° at 10 % of the jog's limit: a step of seconds
        process.stdin.flush()
        assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) > 0.01, timeout=30), "the step never started"
        process.send_signal(signal.SIGSTOP)   # a computer too busy to run ur3dq: the heartbeat stops, the program too
        try:
            assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) < 1e-6, timeout=10)
        finally:
            process.send_signal(signal.SIGCONT)
        process.stdin.write("q")
        process.stdin.flush()
        _, stderr = finish(process)
    assert "J1+ stopped short: program" in stderr and "; the key again goes on" in stderr, stderr
