"""Ctrl-C mid-program, then `run-poses --resume`: against a simulator process, with ur3dq in real subprocesses.

A 6-step pick-and-place program (a joint approach, a linear descent, the gripper on, a linear retract, a joint move
to the place, the gripper off) is interrupted at 10 random instants of its run. Each time, the one error line
names the step and the command to go on, and `--resume` goes on from the step that was running: every run ends
at the last waypoint's target, no step is skipped (the program's own step reports, read here from the primary
interface), the resume path is checked from the arm's actual joints, and the gripper output changes exactly as
in an uninterrupted run (read with ur_rtde).
"""
import queue
import random
import re
import signal
import threading
import time

import numpy as np
import pytest

from cli_support import assert_one_line_error, cli_process, finish
from robot_target import simulator_only
from ur3dq import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.program.steps import DigitalOut, Motion, RelativeWaypoint, Waypoint
from ur3dq.robot.primary_client import PrimaryClient
from ur3dq.store import PoseStore

pytestmark = simulator_only("placing the arm by hand")

MODEL = robot_model("ur3")
START = np.array([0.1, -1.4, 1.5, -1.7, -1.5708, 0.0])
Q_APPROACH = np.array([0.3, -1.3, 1.4, -1.7, -1.5708, 0.2])
Q_PLACE = np.array([0.8, -1.2, 1.3, -1.7, -1.5708, 0.6])
TOOL_OUTPUT_0 = 1 << 16          # actual_digital_output_bits: tool outputs are bits 16-17
INSTANTS = 10
FAST = Motion("joint", 2.0, 4.0)   # rad/s, rad/s²: a short program, so the test stays lean
STEP_REPORT = re.compile(r"ur3dq_step:\s*(\d+)")


def write_program(path):
    """The 6-step program, stored as `record-pose`/`poses` would store it; returns the place waypoint's joints."""
    approach = MODEL.fk(Q_APPROACH)
    pick = approach * DualQuaternion.from_translation([0.0, 0.0, 0.05])   # 5 cm along the tool's z: a descent
    q_pick = MODEL.ik(pick, Q_APPROACH)

    def waypoint(name, pose, joints, motion=FAST):
        return Waypoint(name, Pose.from_dual_quaternion(name, pose, "ur3", joints=tuple(joints)), motion)

    steps = [waypoint("approach", approach, Q_APPROACH), waypoint("pick", pick, q_pick, Motion("linear", 0.25)),
             DigitalOut("grip", "tool", 0, True),
             RelativeWaypoint("retract", "pick", (0, 0, -0.05, 0, 0, 0), motion=Motion("linear", 0.25)),
             waypoint("place", MODEL.fk(Q_PLACE), Q_PLACE), DigitalOut("release", "tool", 0, False)]
    PoseStore(path).update_program(lambda old: (steps, None))


class Recorder:
    """The gripper output's changes (ur_rtde) and the program's step reports (primary interface) while it runs."""

    def __init__(self, arm):
        self.arm = arm
        self.primary = PrimaryClient(arm.host)
        self.messages = self.primary.watch()
        self.changes, self._stop = [], threading.Event()
        self._last = bool(arm.receive.getActualDigitalOutputBits() & TOOL_OUTPUT_0)
        self._thread = threading.Thread(target=self._follow, daemon=True)
        self._thread.start()

    def _follow(self):
        while not self._stop.is_set():
            on = bool(self.arm.receive.getActualDigitalOutputBits() & TOOL_OUTPUT_0)
            if on != self._last:
                self.changes.append(on)
                self._last = on
            time.sleep(0.002)

    def steps(self, settle=0.0):
        """The step reports since the last call, in order; with `settle` > 0, those that come until none has come
        for `settle` s (on a loaded machine the primary interface's reports of a run that just ended come late)."""
        reported = []
        while True:
            try:
                message = self.messages.get(timeout=settle) if settle > 0 else self.messages.get_nowait()
            except queue.Empty:
                return reported
            match = STEP_REPORT.match(getattr(message, "text", "") or "")
            if match:
                reported.append(int(match.group(1)))

    def wait_for_a_step(self, timeout=30):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            message = self.messages.get(timeout=deadline - time.monotonic())
            match = STEP_REPORT.match(getattr(message, "text", "") or "")
            if match:
                return [int(match.group(1))]
        raise AssertionError("the program never reported a step")

    def close(self):
        self._stop.set()
        self._thread.join(1)
        self.primary.unwatch(self.messages)
        self.primary.close()


@pytest.fixture
def program_arm(arm, tmp_path):
    write_program(tmp_path / "poses.json")
    recorder = Recorder(arm)
    yield arm, recorder
    recorder.close()


def run(run_cli, arm, *args):
    return run_cli("--host", arm.host, "run-poses", *args, "--yes")


@pytest.mark.exclusive   # 21 runs of ur3dq, each armed on its 0.1 s heartbeat: not beside the parallel pass
def test_ctrl_c_at_random_instants_then_resume_ends_every_run_where_an_uninterrupted_one_does(
        program_arm, run_cli, tmp_path):
    arm, recorder = program_arm
    place_tcp = MODEL.fk(Q_PLACE).translation
    arm.place(START)
    started = time.monotonic()
    whole = run(run_cli, arm)
    assert whole.returncode == 0, whole.stderr
    assert recorder.steps(settle=0.5) == [1, 2, 3, 4, 5, 6, 7] and recorder.changes == [True, False]
    duration = float(re.search(r"Ran 6 steps in ([\d.]+) s", whole.stdout).group(1))
    assert duration < time.monotonic() - started
    draw = random.Random(33)
    interrupted = []
    for instant in [draw.uniform(0.0, duration) for _ in range(INSTANTS)]:
        arm.place(START)
        recorder.changes.clear()
        recorder.steps()
        with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes") as process:
            reported = recorder.wait_for_a_step()
            time.sleep(instant)
            process.send_signal(signal.SIGINT)
            stdout, stderr = finish(process)
        first_run = reported + recorder.steps(settle=0.5)
        if first_run[-1] == 7:   # the instant fell after the program's end: nothing to resume
            assert process.returncode == 0 or stderr.strip().splitlines()[-1] == "Error: interrupted", stderr
            assert recorder.changes == [True, False], (stdout, recorder.changes)
            assert not (tmp_path / "poses.json.resume").exists()
            continue
        assert process.returncode == 130, stderr
        error = stderr.strip().splitlines()[-1]
        running = max(step for step in first_run if step <= 6)
        interrupted.append(running)
        assert error.startswith(f"Error: interrupted (during step {running} "), (instant, error)
        assert error.endswith(f"— to go on: ur3dq --host {arm.host} run-poses --resume"), error
        at_rest = arm.joints()
        resumed = run(run_cli, arm, "--resume")
        assert resumed.returncode == 0, (instant, resumed.stderr)
        second_run = recorder.steps(settle=0.5)
        assert second_run == list(range(running, 8)), (instant, first_run, second_run)   # no step skipped
        shown = re.search(r"Resuming at step (\d+) of 6.*?\(joints ([-\d. ]+) rad\)", resumed.stderr, re.S)
        assert int(shown.group(1)) == running
        np.testing.assert_allclose([float(v) for v in shown.group(2).split()], at_rest, atol=0.006)
        assert "Path check (no cell file): clear" in resumed.stderr   # the check ran on the resume plan
        assert np.linalg.norm(arm.tcp_pose()[:3] - place_tcp) < 5e-4, instant
        assert recorder.changes == [True, False], (instant, running, recorder.changes)
        assert not (tmp_path / "poses.json.resume").exists()
    assert len(set(interrupted)) >= 3, interrupted   # the instants fell in several steps


def test_resume_is_refused_after_the_store_changed_and_with_nothing_to_resume(program_arm, run_cli, tmp_path):
    arm, recorder = program_arm
    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes") as process:
        recorder.wait_for_a_step()
        process.send_signal(signal.SIGINT)
        finish(process)
    assert process.returncode == 130 and (tmp_path / "poses.json.resume").exists()
    assert run_cli("--host", arm.host, "poses", "set", "pick", "--speed", "0.05").returncode == 0
    changed = run(run_cli, arm, "--resume")
    assert changed.returncode == 4 and "resume refused: poses.json changed since the run stopped" in changed.stderr
    (tmp_path / "poses.json.resume").unlink()
    nothing = run(run_cli, arm, "--resume")
    assert nothing.returncode == 4 and "nothing to resume" in nothing.stderr


def test_resume_on_another_arm_is_refused(program_arm, run_cli, tmp_path):
    from powered_simulator import powered_simulator

    arm, recorder = program_arm
    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes") as process:
        recorder.wait_for_a_step()
        process.send_signal(signal.SIGINT)
        finish(process)
    assert process.returncode == 130
    with powered_simulator(model="ur3", extra_args=("--calibration", "factory:7")) as other:
        refused = run_cli("--host", other.host, "run-poses", "--resume", "--yes")
    assert refused.returncode == 4, refused.stderr
    assert "resume refused: the run stopped on a ur3 (calibration" in refused.stderr
    assert (tmp_path / "poses.json.resume").exists()   # still there for the right arm


@pytest.mark.parametrize("pause_signal", [signal.SIGUSR1, signal.SIGTSTP])
def test_a_signal_pauses_the_run_on_its_path_and_sigcont_resumes_it(program_arm, run_cli, tmp_path, pause_signal):
    arm, recorder = program_arm
    arm.place(START)
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes") as process:
        recorder.wait_for_a_step()
        time.sleep(0.3)
        process.send_signal(pause_signal)
        deadline = time.monotonic() + 5
        while np.max(np.abs(arm.joint_speeds())) > 1e-6:
            assert time.monotonic() < deadline, "the arm never came to rest"
            time.sleep(0.01)
        held = arm.joints()
        time.sleep(1.0)
        assert np.max(np.abs(arm.joints() - held)) < 1e-9   # paused: nothing moves
        process.send_signal(signal.SIGCONT)
        stdout, stderr = finish(process)
    assert process.returncode == 0, stderr
    assert "Paused during step" in stderr and "Resumed." in stderr
    assert np.linalg.norm(arm.tcp_pose()[:3] - MODEL.fk(Q_PLACE).translation) < 5e-4
    assert recorder.changes == [True, False]


def test_a_fault_mid_program_names_the_step_the_outputs_left_on_and_the_way_on(run_cli, tmp_path):
    """A protective stop during the retract, the gripper on: a simulator of its own (the stop stays latched)."""
    from cli_support import SimulatedArm
    from powered_simulator import powered_simulator
    from sim_ursim.control_channel import send_request

    write_program(tmp_path / "poses.json")
    with powered_simulator(model="ur3", initial_q=list(START)) as simulator:
        arm = SimulatedArm(simulator.host)
        recorder = Recorder(arm)
        try:
            with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes") as process:
                while 4 not in recorder.wait_for_a_step():   # the retract: the gripper is on
                    pass
                time.sleep(0.1)
                assert send_request(arm.host, "protective-stop", reason="test")["ok"]
                _, stderr = finish(process)
        finally:
            recorder.close()
            arm.receive.disconnect()
    assert process.returncode == 6, stderr
    error = stderr.strip().splitlines()[-1]
    assert error.endswith(f"(during step 4 'retract'; tool output 0 still on) — to go on: ur3dq --host "
                          f"{arm.host} run-poses --resume"), error
    assert "Stopped during step 4 of 6, 'retract' (linear relative waypoint)." in stderr
    assert "The arm is at rest at x " in stderr
    assert "Tool output 0 still on (switched on by the program)." in stderr


def test_a_run_into_a_latched_protective_stop_names_it_and_the_unlock(run_cli, tmp_path):
    """Nothing is sent while a protective stop is latched (a controller would not run it either): one error line
    naming the stop and the command that unlocks it, exit 6, the arm where it was."""
    from powered_simulator import powered_simulator
    from sim_ursim.control_channel import send_request

    write_program(tmp_path / "poses.json")
    with powered_simulator(model="ur3", initial_q=list(START)) as simulator:
        assert send_request(simulator.host, "protective-stop", reason="test")["ok"]
        result = run_cli("--host", simulator.host, "run-poses", "--yes")
        state = send_request(simulator.host, "status")["state"]
    assert_one_line_error(result, 6, "protective stop", "ur3dq robot unlock")
    assert not state["program_running"] and np.allclose(state["q"], START, atol=1e-9)


def test_a_replay_of_stored_poses_resumes_from_the_move_it_stopped_in(arm, run_cli, tmp_path):
    places = [Q_APPROACH, Q_PLACE, START]
    PoseStore(tmp_path / "poses.json").add_many([Pose.from_dual_quaternion(name, MODEL.fk(q), "ur3", joints=tuple(q))
                                                 for name, q in zip("abc", places, strict=True)])
    arm.place(START)
    primary = PrimaryClient(arm.host)
    messages = primary.watch()
    try:
        with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes", "--speed", "0.5") as process:
            starts = 0
            while starts < 2:   # the second move's program started: stop during move 2
                message = messages.get(timeout=30)
                starts += getattr(message, "title", "").endswith("_STARTED") and message.text.startswith("ur3dq_move")
            time.sleep(0.3)
            process.send_signal(signal.SIGINT)
            _, stderr = finish(process)
    finally:
        primary.close()
    assert process.returncode == 130, stderr
    assert "(during move 2 of 3, to 'b')" in stderr.strip().splitlines()[-1]
    resumed = run(run_cli, arm, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert "Resuming the replay at move 2, to 'b'" in resumed.stderr
    np.testing.assert_allclose(arm.joints(), START, atol=1e-3)


def test_in_a_terminal_p_pauses_s_stops_and_resume_goes_on(program_arm, run_cli, tmp_path):
    from cli_support import Terminal

    arm, recorder = program_arm
    arm.place(START)
    terminal = Terminal(tmp_path, "--host", arm.host, "run-poses", "--yes")
    try:
        terminal.wait_for("p pauses, s stops, q quits")
        recorder.wait_for_a_step()
        time.sleep(0.2)
        terminal.press("p")
        terminal.wait_for("Paused during step")
        terminal.wait_for("r resume, s stop (go on later with --resume), q quit.")
        assert np.max(np.abs(arm.joint_speeds())) < 1e-3   # "Paused" is said once the arm rests
        held = arm.joints()
        time.sleep(0.5)
        np.testing.assert_allclose(arm.joints(), held, atol=1e-5)   # paused on its path: nothing moves
        terminal.press("s")
        terminal.wait_for("Error: stopped by the operator (during step ")
        assert terminal.process.wait(20) == 130
    finally:
        terminal.close()
    resumed = run(run_cli, arm, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert np.linalg.norm(arm.tcp_pose()[:3] - MODEL.fk(Q_PLACE).translation) < 5e-4
    assert recorder.changes == [True, False]
