"""The CLI against a real sim_ursim: record, replay, teach, Ctrl-C, exported programs; checked with ur_rtde."""
import json
import signal
import socket
import subprocess
import time

import numpy as np
import pytest

from cli_support import UR3DQ, assert_one_line_error, cli_env, cli_process, run_telling_numba
from polling import wait_for
from robot_target import simulator_only
from ur3dq.store import PoseStore

pytestmark = simulator_only("placing the arm by hand")

PLACES = [np.array(q) for q in ([0.0, -1.2, 1.0, -1.4, -1.57, 0.0], [0.8, -1.0, 1.3, -1.9, -1.57, 0.5],
                                [-0.7, -1.6, 1.6, -1.6, -1.57, -0.3])]
PARK = np.array([0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0])
FAST = ("--speed", "3", "--acceleration", "20")


def test_record_several_poses_then_replay_them(arm, run_cli, tmp_path):
    for index, q in enumerate(PLACES, start=1):
        arm.place(q)
        result = run_cli("--host", arm.host, "record-pose", "--name", f"p{index}", "--yes")
        assert result.returncode == 0, result.stderr
        assert "Recorded 'p" in result.stdout and "dual quaternion" in result.stdout
    stored = PoseStore(tmp_path / "poses.json").load()
    assert [p.name for p in stored] == ["p1", "p2", "p3"]
    assert all(p.robot_model == "ur3" and p.robot_serial is None for p in stored)  # CB3 has no serial command
    for pose, q in zip(stored, PLACES):
        np.testing.assert_allclose(pose.joints, q, atol=1e-9)

    arm.place(PARK)
    result = run_cli("--host", arm.host, "run-poses", "--yes", *FAST, "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert [step["pose"] for step in report["plan"]] == ["p1", "p2", "p3"]
    for step, q in zip(report["plan"], PLACES):
        np.testing.assert_allclose(step["joints"], q, atol=1e-6)  # IK followed the recorded joints
    assert all(r["error_m"] < 1e-4 and r["error_rad"] < 1e-3 for r in report["reached"])
    # where the simulated arm ended, read independently through ur_rtde
    np.testing.assert_allclose(arm.joints(), PLACES[2], atol=1e-4)
    np.testing.assert_allclose(arm.tcp_pose()[:3], stored[2].ur_pose[:3], atol=1e-4)

    result = run_cli("--host", arm.host, "run-poses", "p2", "p1", "--joints", "--yes", *FAST)
    assert result.returncode == 0, result.stderr
    assert "Where the arm ended" in result.stdout
    np.testing.assert_allclose(arm.joints(), PLACES[0], atol=1e-4)


def test_blended_loop_runs_every_pass_and_ends_at_the_last_pose(arm, run_cli, tmp_path):
    for q in PLACES:
        arm.place(q)
        assert run_cli("--host", arm.host, "record-pose", "--yes").returncode == 0
    arm.place(PARK)
    result = run_cli("--host", arm.host, "run-poses", "--yes", *FAST, "--blend", "0.01", "--loop", "2", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    one_pass = sum(step["duration"] for step in report["plan"])
    (reached,) = report["reached"]
    assert reached["pose"] == "pose-3" and reached["error_m"] < 1e-4
    assert reached["seconds"] > one_pass, "two blended passes took less than one stop-and-go pass"
    np.testing.assert_allclose(arm.joints(), PLACES[2], atol=1e-4)


def test_the_urx_backend_records_and_replays_too(arm, run_cli, tmp_path):
    arm.place(PLACES[1])
    assert run_cli("--backend", "urx", "--host", arm.host, "record-pose", "--name", "u", "--yes").returncode == 0
    np.testing.assert_allclose(PoseStore(tmp_path / "poses.json").get("u").joints, PLACES[1], atol=1e-9)
    arm.place(PARK)
    result = run_cli("--backend", "urx", "--host", arm.host, "run-poses", "--yes", *FAST)
    assert result.returncode == 0, result.stderr
    assert "tried 11 times" not in result.stderr  # urx's parser warnings stay out of the user's terminal
    np.testing.assert_allclose(arm.joints(), PLACES[1], atol=1e-4)


def test_dry_run_plans_but_does_not_move(arm, run_cli, tmp_path):
    arm.place(PLACES[0])
    assert run_cli("--host", arm.host, "record-pose", "--name", "far", "--yes").returncode == 0
    arm.place(PARK)
    result = run_cli("--host", arm.host, "run-poses", "--dry-run")
    assert result.returncode == 0, result.stderr
    assert "far" in result.stdout and "IK nearest recorded" in result.stdout
    time.sleep(0.3)
    np.testing.assert_allclose(arm.joints(), PARK, atol=1e-9)


@pytest.mark.parametrize("inherited_sigint", [signal.SIG_DFL, signal.SIG_IGN], ids=["sigint", "started-ignoring-it"])
def test_ctrl_c_stops_the_arm(arm, run_cli, tmp_path, inherited_sigint):
    """Also when ur3dq started with SIGINT ignored (a script's `ur3dq run-poses &`): stopping is the safe side."""
    arm.place(PLACES[0])
    assert run_cli("--host", arm.host, "record-pose", "--name", "target", "--yes").returncode == 0
    arm.place(PLACES[1])
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--yes", "--speed", "0.15",
                     inherited_sigint=inherited_sigint) as process:
        deadline = time.monotonic() + 20
        while np.max(np.abs(arm.joint_speeds())) < 0.05:  # wait until the arm is clearly moving
            assert time.monotonic() < deadline and process.poll() is None, "the arm never started moving"
            time.sleep(0.02)
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=20)
    assert process.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1].startswith("Error: interrupted")
    # stopj decelerates at 2 rad/s² from 0.15 rad/s: well under a second
    assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) < 1e-6, timeout=2.0), "the arm still moves after Ctrl-C"
    assert np.max(np.abs(arm.joints() - PLACES[0])) > 0.1, "the arm reached the target: Ctrl-C did not stop it"


def test_record_pose_solves_its_one_pose_without_loading_numba(arm, tmp_path):
    """record-pose shows one FK (its check against the controller's TCP): the kernels run as Python, as for `ur3dq
    fk`, so a recorded pose costs no numba start-up; the table is the one compiled kernels print."""
    arm.place(PLACES[1])
    shown = {}
    for jit in ("", "0"):   # as the command starts, then with compiled kernels asked for
        table, numba = run_telling_numba(tmp_path, jit, "--host", arm.host, "--store",
                                         str(tmp_path / f"poses{jit}.json"), "record-pose", "--yes")
        shown[jit] = ([line for line in table if "Recorded" not in line], numba)
    assert shown[""][1] == "False" and shown["0"][1] == "True"
    assert shown[""][0] == shown["0"][0]
    assert any("model FK check" in line and "0.000 mm / 0.000°" in line for line in shown[""][0]), shown[""][0]


def test_teach_records_each_enter_and_ends_freedrive(arm, tmp_path):
    from sim_ursim.control_channel import send_request

    arm.place(PLACES[0])
    with cli_process(tmp_path, "--host", arm.host, "record-pose", "--teach", "--name", "t",
                     stdin=subprocess.PIPE) as process:
        assert "Freedrive is on" in process.stderr.readline()
        process.stdin.write("\n")
        process.stdin.flush()
        assert "recorded 't-1':" in process.stderr.readline()
        assert process.stderr.readline().startswith("  p[")  # the pose vector, on a line of its own
        assert send_request(arm.host, "move-by-hand", q=list(PLACES[1]))["ok"]  # the operator moves the arm
        arm.wait_until_at(PLACES[1])
        process.stdin.write("station\n")
        process.stdin.flush()
        assert "recorded 'station':" in process.stderr.readline()
        assert process.stderr.readline().startswith("  p[")  # the pose vector, on a line of its own
        process.stdin.write("station\n")  # a taken name is refused, and teaching goes on
        process.stdin.flush()
        assert "not recorded: a pose named 'station' already exists" in process.stderr.readline()
        process.stdin.write("q\n")
        process.stdin.flush()
        stdout, stderr = process.communicate(timeout=20)
    assert process.returncode == 0, stderr
    assert "Recorded 2 poses" in stdout
    stored = PoseStore(tmp_path / "poses.json").load()
    assert [p.name for p in stored] == ["t-1", "station"]
    np.testing.assert_allclose(stored[0].joints, PLACES[0], atol=1e-9)
    np.testing.assert_allclose(stored[1].joints, PLACES[1], atol=1e-9)
    refused = send_request(arm.host, "move-by-hand", q=list(PLACES[0]))
    assert not refused["ok"] and "freedrive" in refused["error"]  # freedrive is off again


def test_two_record_pose_processes_at_once_keep_every_pose(arm, tmp_path):
    arm.place(PLACES[2])
    loop = f"for i in 1 2 3; do {UR3DQ} --host {arm.host} record-pose --yes --note $0 || exit 1; done"
    writers = [subprocess.Popen(["bash", "-c", loop, name], cwd=tmp_path, env=cli_env(tmp_path),
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) for name in "ab"]
    errors = [writer.communicate(timeout=120)[1] for writer in writers]
    assert [writer.returncode for writer in writers] == [0, 0], errors
    stored = PoseStore(tmp_path / "poses.json").load()
    assert sorted(p.name for p in stored) == sorted(f"pose-{n}" for n in range(1, 7))
    assert sorted(p.note for p in stored) == ["a"] * 3 + ["b"] * 3


def test_taken_name_or_no_answer_records_nothing(arm, run_cli, tmp_path):
    assert run_cli("--host", arm.host, "record-pose", "--name", "home", "--yes").returncode == 0
    store = tmp_path / "poses.json"
    before = store.read_bytes()
    assert_one_line_error(run_cli("--host", arm.host, "record-pose", "--name", "home", "--yes"), 3,
                          "'home' already exists")
    declined = run_cli("--host", arm.host, "record-pose", input="n\n")  # a deliberate no: not an error
    assert declined.returncode == 1 and "Record this pose?" in declined.stderr
    assert "Answered no: nothing done." in declined.stderr
    assert "Error" not in declined.stderr
    assert store.read_bytes() == before


def test_unreachable_stored_pose_is_refused_before_moving(arm, run_cli, tmp_path):
    (tmp_path / "far.txt").write_text("1 0 0 0 0 2.0 0 0\n")
    assert run_cli("poses", "import", "far.txt").returncode == 0
    before = (tmp_path / "poses.json").read_bytes()
    arm.place(PARK)
    assert_one_line_error(run_cli("--host", arm.host, "run-poses", "--yes"), 4, "pose 'far-1' is unreachable")
    np.testing.assert_allclose(arm.joints(), PARK, atol=1e-9)
    assert (tmp_path / "poses.json").read_bytes() == before


def test_exported_program_runs_on_the_controller(arm, run_cli, tmp_path):
    for q in PLACES[:2]:
        arm.place(q)
        assert run_cli("--host", arm.host, "record-pose", "--yes").returncode == 0
    arm.place(PARK)
    result = run_cli("export-urscript", "-o", "cell.script", *FAST)
    assert result.returncode == 0, result.stderr
    with socket.create_connection((arm.host, 30002), timeout=5) as connection:
        connection.sendall((tmp_path / "cell.script").read_bytes())
        connection.shutdown(socket.SHUT_WR)
        # open until the program has run to its last pose (a script followed at once by a close is a sim bug)
        arm.wait_until_at(PLACES[1], timeout=15, tolerance=1e-4)


def test_no_robot_configured_or_reachable(run_cli, tmp_path):
    assert_one_line_error(run_cli("status"), 5, "--host", "UR3DQ_HOST", "ur3dq sim start")
    from sim_ursim.launch import free_loopback_address

    nobody = free_loopback_address()
    assert_one_line_error(run_cli("--host", nobody, "record-pose", "--yes"), 5, nobody)
    assert not (tmp_path / "poses.json").exists()


def test_sim_start_status_stop_and_commands_use_it(run_cli, tmp_path):
    started = run_cli("sim", "start", "--json")
    assert started.returncode == 0, started.stderr
    state = json.loads(started.stdout)
    try:
        status = json.loads(run_cli("sim", "status", "--json").stdout)
        assert status["running"] and status["host"] == state["host"]
        robot = run_cli("status", "--json")  # no --host: the embedded simulator
        assert robot.returncode == 0, robot.stderr
        assert json.loads(robot.stdout)["host"] == state["host"]
        assert json.loads(robot.stdout)["robot_mode"] == "RUNNING"  # sim start powers on, releases the brakes
        assert_one_line_error(run_cli("sim", "start"), 8, "already runs")
    finally:
        stopped = run_cli("sim", "stop")
    assert stopped.returncode == 0 and "Stopped" in stopped.stdout
    assert not json.loads(run_cli("sim", "status", "--json").stdout)["running"]
    assert_one_line_error(run_cli("status"), 5, "ur3dq sim start")


@pytest.mark.timeout(120)
def test_demo_runs_the_whole_job(run_cli, tmp_path):
    result = run_cli("demo", "--save", "demo.json", "--speed", "3", "--acceleration", "20", timeout=110)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Every pose reached" in result.stdout
    assert [p.name for p in PoseStore(tmp_path / "demo.json").load()] == ["demo-1", "demo-2", "demo-3", "demo-4"]
    # the cell-program part: a pick-and-place run as one program, each step reported as it ran
    program = PoseStore(tmp_path / "demo-program.json").load_program()
    assert [step.name for step in program] == ["approach", "demo-1", "close-gripper", "settle", "retract", "demo-2",
                                               "open-gripper"]
    for position, step in enumerate(program, start=1):
        assert f"step {position}: {step.name}" in result.stdout
