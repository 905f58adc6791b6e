"""A cell program recorded, edited and run through the CLI against a simulator subprocess, checked through ur_rtde:
record-pose with a move type and placement, a relative waypoint that lands at its tool-frame offset also after its
base is retouched, run-poses --from/--to, and export-urscript writing the program run-poses sends."""
import numpy as np

from robot_target import simulator_only
from ur3dq.dualquat import DualQuaternion
from ur3dq.store import PoseStore

pytestmark = simulator_only("placing the arm by hand")

PICK = np.array([0.4, -1.3, 1.5, -1.8, -1.5707963267948966, 0.3])
ELSEWHERE = np.array([0.0, -1.5707963267948966, 1.2, -1.2, -1.5707963267948966, 0.0])


def test_record_edit_run_and_retouch_a_cell_program(arm, run_cli, tmp_path):
    arm.place(PICK)
    result = run_cli("--host", arm.host, "record-pose", "--name", "pick", "--move", "linear", "--speed", "0.05",
                     "--yes")
    assert result.returncode == 0, result.stderr
    assert run_cli("poses", "offset", "approach", "--from", "pick", "--z", "-0.05", "--before", "pick").returncode == 0
    assert run_cli("poses", "add-step", "--after", "pick", "tool-out", "1", "on").returncode == 0
    assert run_cli("poses", "copy", "approach", "retract", "--after", "tool-out-1").returncode == 0
    assert run_cli("poses", "set", "retract", "--move", "linear", "--speed", "0.1").returncode == 0
    listed = run_cli("poses", "list")
    assert [line.split("│")[2].strip() for line in listed.stdout.splitlines() if line.count("│") > 3] == [
        "approach", "pick", "tool-out-1", "retract"]
    arm.place(ELSEWHERE)
    result = run_cli("--host", arm.host, "run-poses", "--yes")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Ran 4 steps" in result.stdout
    assert arm.receive.getActualDigitalOutputBits() & (1 << 17)   # tool output 1 is on
    pick = PoseStore(tmp_path / "poses.json").get("pick")
    expected = pick.dq.transform_point([0, 0, -0.05])
    assert np.linalg.norm(arm.tcp_pose()[:3] - expected) <= 1e-4

    # re-teach pick elsewhere: the relative waypoints follow it
    moved = PICK + [0.2, 0.1, -0.1, 0.1, 0.2, 0.3]
    arm.place(moved)
    assert run_cli("--host", arm.host, "poses", "retouch", "pick", "--yes").returncode == 0
    assert [s.name for s in PoseStore(tmp_path / "poses.json").load_program()] == [
        "approach", "pick", "tool-out-1", "retract"]
    arm.place(ELSEWHERE)
    result = run_cli("--host", arm.host, "run-poses", "--from", "approach", "--to", "pick", "--yes")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Ran 2 steps" in result.stdout
    np.testing.assert_allclose(arm.joints(), moved, atol=1e-4)
    result = run_cli("--host", arm.host, "run-poses", "--from", "retract", "--yes")
    assert result.returncode == 0, result.stdout + result.stderr
    retouched = DualQuaternion.from_ur_pose(PoseStore(tmp_path / "poses.json").get("pick").ur_pose)
    assert np.linalg.norm(arm.tcp_pose()[:3] - retouched.transform_point([0, 0, -0.05])) <= 1e-4

    exported = run_cli("export-urscript", "--from", "pick", "--to", "retract")
    assert exported.returncode == 0, exported.stderr
    assert "movel(" in exported.stdout and "set_tool_digital_out(1, True)" in exported.stdout
    assert 'textmsg("ur3dq_step:", 2)' in exported.stdout and "ur3dq_step:\", 1)" not in exported.stdout


def test_ctrl_c_stops_a_running_cell_program(arm, run_cli, tmp_path):
    import signal

    from cli_support import cli_process
    from polling import wait_for

    arm.place(PICK)
    assert run_cli("--host", arm.host, "record-pose", "--name", "pick", "--yes").returncode == 0
    assert run_cli("poses", "offset", "far", "--from", "pick", "--z", "-0.15", "--move", "linear",
                   "--speed", "0.02").returncode == 0
    assert run_cli("poses", "add-step", "tool-out", "0", "on").returncode == 0
    assert arm.receive.getActualDigitalOutputBits() & (1 << 16) == 0
    with cli_process(tmp_path, "--host", arm.host, "run-poses", "--from", "far", "--yes") as process:
        assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) > 0.01 or process.poll() is not None, 20)
        assert process.poll() is None, process.communicate()
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=20)
    assert process.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1].startswith("Error: interrupted")
    assert wait_for(lambda: np.max(np.abs(arm.joint_speeds())) < 1e-6, 2.0), "the arm still moves after Ctrl-C"
    far = PoseStore(tmp_path / "poses.json").get("pick").dq.transform_point([0, 0, -0.15])
    assert np.linalg.norm(arm.tcp_pose()[:3] - far) > 0.05   # stopped on the way, well short of "far"
    assert arm.receive.getActualDigitalOutputBits() & (1 << 16) == 0    # the program did not go on to its output
