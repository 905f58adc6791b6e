"""The CLI without a robot, through real `ur3dq` subprocesses: kinematics, the pose store, files, bad input."""
import json
import math
from pathlib import Path

import numpy as np
import pytest
import ur_analytic_ik
from click.testing import CliRunner

from cli_support import assert_one_line_error, run_telling_numba
from ur3dq.cli import cli
from ur3dq.cli.app import FEW_POSES, python_kernels_pay
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model, robot_model_from_dh
from ur3dq.pose import Pose
from ur3dq.program.steps import Motion, RelativeWaypoint, Waypoint
from ur3dq.store import PoseStore

THESIS_HOME = [0, -math.pi / 2, 0, -math.pi / 2, 0, 0]
# Two UR3 configurations (rad) and their FK lines, written as the thesis' text file would hold them.
CONFIGS = [[0.0, -1.2, 1.0, -1.4, -1.57, 0.0], [0.8, -1.0, 1.3, -1.9, -1.57, 0.5]]


def thesis_lines_of(configs):
    """Thesis text lines of the UR3's TCP at `configs`, from ur_analytic_ik's FK (an independent peer)."""
    return "".join(DualQuaternion.from_matrix(ur_analytic_ik.ur3.forward_kinematics(*q)).to_thesis_line() + "\n"
                   for q in configs)


@pytest.fixture
def thesis_store(tmp_path, run_cli):
    """A store holding the two CONFIGS poses imported from a thesis text file (names cell-1, cell-2)."""
    (tmp_path / "cell.txt").write_text(thesis_lines_of(CONFIGS))
    result = run_cli("poses", "import", "cell.txt")
    assert result.returncode == 0, result.stderr
    return tmp_path / "poses.json"


def test_help_teaches_with_examples(run_cli):
    top = run_cli("--help")
    assert top.returncode == 0 and "Exit codes:" in top.stdout and "UR3DQ_HOST" in top.stdout
    runner = CliRunner()  # the same click commands in-process: 12 more interpreter start-ups would teach nothing
    for command in (["record-pose"], ["run-poses"], ["fk"], ["ik"], ["export-urscript"], ["plot"], ["demo"],
                    ["sim"], ["poses"], ["poses", "import"], ["status"]):
        result = runner.invoke(cli, [*command, "--help"])
        assert result.exit_code == 0 and "Example" in result.output, command


def test_fk_of_the_thesis_home_pose(run_cli):
    result = run_cli("fk", *THESIS_HOME, "--json")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    np.testing.assert_allclose(out["ur_pose"][:3], [0, -0.19425, 0.69415], atol=1e-12)
    in_degrees = json.loads(run_cli("--deg", "fk", 0, -90, 0, -90, 0, 0, "--json").stdout)
    np.testing.assert_allclose(in_degrees["dual_quaternion"], out["dual_quaternion"], atol=1e-15)
    assert "thesis line" in run_cli("fk", *THESIS_HOME).stdout


def test_ik_lists_every_solution_and_each_reaches_the_pose(run_cli):
    target = ur_analytic_ik.ur3.forward_kinematics(*CONFIGS[0])
    pose = DualQuaternion.from_matrix(target).to_ur_pose()
    result = run_cli("ik", *pose, "--near", *CONFIGS[0], "--json")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    assert len(out["solutions"]) == len(ur_analytic_ik.ur3.inverse_kinematics(target)) == 4
    for q in out["solutions"]:
        np.testing.assert_allclose(ur_analytic_ik.ur3.forward_kinematics(*q), target, atol=1e-9)
    np.testing.assert_allclose(out["chosen"], CONFIGS[0], atol=1e-9)
    table = run_cli("--deg", "ik", *pose).stdout
    assert "4 IK solutions" in table and table.count("°") > 24


def test_unreachable_pose_is_one_clear_error(run_in_process):
    assert_one_line_error(run_in_process("ik", 2, 0, 0, 0, 0, 0), 4, "unreachable", "too far")


def test_bad_numbers_are_one_clear_error(run_in_process):
    assert_one_line_error(run_in_process("fk", 0, 0, 0), 4, "expected 6 joint angles, got 3")
    assert_one_line_error(run_in_process("fk", 0, 0, 0, 0, 0, "nan"), 4, "'nan' is not an angle")
    assert_one_line_error(run_in_process("fk", 0, 0, 0, 0, 0, "x"), 4, "'x' is not an angle", "5deg")


def test_poses_import_list_show_rename_rm_export(tmp_path, run_cli, thesis_store):
    listed = json.loads(run_cli("poses", "list", "--json").stdout)["poses"]
    assert [p["name"] for p in listed] == ["cell-1", "cell-2"]
    assert all(p["joints"] is None and p["robot_model"] == "ur3" for p in listed)
    shown = json.loads(run_cli("poses", "show", "cell-2", "--json").stdout)["step"]
    expected = DualQuaternion.from_matrix(ur_analytic_ik.ur3.forward_kinematics(*CONFIGS[1]))
    assert DualQuaternion.from_array(shown["dual_quaternion"]).is_close(expected, 1e-12, 1e-12)
    assert run_cli("poses", "rename", "cell-2", "place").returncode == 0
    assert run_cli("poses", "rm", "cell-1", "--yes").returncode == 0
    assert [p.name for p in PoseStore(thesis_store).load()] == ["place"]
    exported = run_cli("poses", "export", "-").stdout.split()
    np.testing.assert_allclose([float(x) for x in exported], [float(x) for x in thesis_lines_of(CONFIGS[1:]).split()],
                               atol=1e-12)
    assert run_cli("poses", "export", "backup.json", "--format", "json").returncode == 0
    assert [p.name for p in PoseStore(tmp_path / "backup.json").load()] == ["place"]
    reimported = run_cli("poses", "import", "backup.json", "--json")
    assert json.loads(reimported.stdout)["imported"] == ["place-1"]


def test_rm_without_an_answer_changes_nothing(run_in_process, thesis_store):
    before = thesis_store.read_bytes()
    assert_one_line_error(run_in_process("poses", "rm", "cell-1"), 1, "--yes")
    declined = run_in_process("poses", "rm", "cell-1", input="n\n")
    assert declined.returncode == 1
    # a deliberate "no" is the user's choice, not an error (issue 14 item 12)
    assert "Error" not in declined.stderr and "Answered no" in declined.stderr and "nothing done" in declined.stderr
    assert thesis_store.read_bytes() == before


@pytest.mark.parametrize("command", [
    ["poses", "rm", "nope", "--yes"], ["run-poses", "nope", "--dry-run"], ["export-urscript", "cell-1", "nope"],
])
def test_unknown_pose_name_is_a_clear_error_and_changes_nothing(run_in_process, thesis_store, command):
    before = thesis_store.read_bytes()
    assert_one_line_error(run_in_process(*command), 3, "no pose named 'nope'", "cell-1")
    assert thesis_store.read_bytes() == before


def corrupt_store_text(tmp_path):
    """A store with a JSON syntax error on line 3."""
    return '{"schema": "ur3dq.poses", "version": 1,\n "poses": [\n  {"name": "a",,}\n ]}\n'


def nan_store_text(tmp_path):
    """A valid store file with NaN typed into the second pose's joints."""
    scratch = PoseStore(tmp_path / "scratch.json")
    for name, q in zip(("a", "b"), CONFIGS):
        pose = DualQuaternion.from_matrix(ur_analytic_ik.ur3.forward_kinematics(*q))
        scratch.add(Pose.from_dual_quaternion(name, pose, "ur3", joints=q))
    text = scratch.path.read_text()
    return text.replace(f'"joints": [{CONFIGS[1][0]}', '"joints": [NaN')


BROKEN = {
    "corrupt": (corrupt_store_text, "poses.json:3:", "not valid JSON"),
    "nan": (nan_store_text, "poses.json:6: pose #2 'b'", "joints contains NaN"),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
@pytest.mark.parametrize("command", [["poses", "list"], ["poses", "import", "more.txt"], ["record-pose", "--yes"]])
def test_broken_store_is_one_clear_error_and_never_overwritten(tmp_path, run_in_process, case, command):
    make_text, where, what = BROKEN[case]
    text = make_text(tmp_path)
    store = tmp_path / "poses.json"
    store.write_text(text)
    (tmp_path / "more.txt").write_text(thesis_lines_of(CONFIGS[:1]))
    assert_one_line_error(run_in_process(*command), 3, where, what)
    assert store.read_text() == text


def test_an_import_file_that_is_not_utf8_names_its_line_and_byte(tmp_path, run_in_process):
    (tmp_path / "more.txt").write_bytes(thesis_lines_of(CONFIGS[:1]).encode() + b"\xe9\n")
    assert_one_line_error(run_in_process("poses", "import", "more.txt"), 3, "more.txt:2: not UTF-8 text (byte 0xe9",
                          "save it as UTF-8")
    assert not (tmp_path / "poses.json").exists()


def test_an_import_reads_its_file_once(tmp_path, run_in_process, monkeypatch):
    # Read twice, a file being written by another program could be taken for thesis lines and parsed as JSON.
    (tmp_path / "more.txt").write_text(thesis_lines_of(CONFIGS))
    reads = []
    read_text = Path.read_text
    monkeypatch.setattr(Path, "read_text", lambda path, *a, **k: reads.append(path.name) or read_text(path, *a, **k))
    assert run_in_process("poses", "import", "more.txt").returncode == 0
    assert reads.count("more.txt") == 1


def write_random_program(path, waypoints, relative=0):
    """A cell program of `waypoints` random UR3 waypoints, every other move a line, then `relative` relative waypoints
    5 cm above the first."""
    model, draw = robot_model("ur3"), np.random.default_rng(5)
    start = np.array([0.1, -1.4, 1.5, -1.7, -1.5708, 0.0])
    steps = []
    for index in range(waypoints):
        q = start + draw.uniform(-0.3, 0.3, 6)
        pose = Pose.from_dual_quaternion(f"w{index}", model.fk(q), "ur3", joints=tuple(q))
        steps.append(Waypoint(f"w{index}", pose, Motion("linear", 0.1) if index % 2 else Motion("joint", 1.0, 1.4)))
    steps += [RelativeWaypoint(f"r{index}", "w0", (0, 0, -0.05, 0, 0, 0)) for index in range(relative)]
    PoseStore(path).update_program(lambda old: (steps, None))


def test_check_runs_the_kernels_as_python_up_to_few_poses_and_says_the_same(tmp_path):
    """Up to FEW_POSES waypoints `ur3dq check` runs its kinematics as Python (no numba start-up) and prints what
    compiled kernels print; one more, and it loads the compiled ones."""
    write_random_program(tmp_path / "poses.json", FEW_POSES)
    shown = {jit: run_telling_numba(tmp_path, jit, "check") for jit in ("", "0")}
    assert shown[""][1] == "False" and shown["0"][1] == "True"
    assert shown[""][0] == shown["0"][0] and "Path check" in shown[""][0][0]
    write_random_program(tmp_path / "poses.json", FEW_POSES + 1)
    assert run_telling_numba(tmp_path, "", "check")[1] == "True"
    write_random_program(tmp_path / "poses.json", FEW_POSES, relative=1)   # steps counted, as run-poses counts them
    assert run_telling_numba(tmp_path, "", "check")[1] == "True"


def test_plot_draws_a_cell_program_as_run_poses_plans_it(tmp_path, run_in_process):
    """The arm at every waypoint of the program, relative ones included, in the joints run-poses moves to; its
    steps counted as run-poses counts them, for the kernels' mode too."""
    write_random_program(tmp_path / "poses.json", 4, relative=1)
    planned = json.loads(run_in_process("--json", "run-poses", "--dry-run").stdout)["plan"]
    drawn = json.loads(run_in_process("--json", "plot", "-o", "path.png").stdout)["arms"]
    assert [arm["name"] for arm in drawn] == ["w0", "w1", "w2", "w3", "r0"] == [step["step"] for step in planned]
    np.testing.assert_allclose([arm["joints"] for arm in drawn], [step["joints"] for step in planned], atol=1e-12)
    write_random_program(tmp_path / "poses.json", FEW_POSES, relative=1)
    assert run_telling_numba(tmp_path, "", "plot", "-o", "path.png", "--yes")[1] == "True"


def test_a_calibrated_arm_keeps_the_compiled_kernels_for_more_than_one_pose():
    """Its path check runs Newton steps at every sample: as Python, a 20-waypoint check took 3.6 s, not 1.2 s."""
    nominal = robot_model("ur5e")
    dh = nominal.dh
    calibrated = robot_model_from_dh("ur5e", [1e-4, *dh.a[1:]], dh.d, dh.alpha, dh.theta)   # a1 off nominal
    assert python_kernels_pay(1, calibrated) and python_kernels_pay(1)
    assert python_kernels_pay(FEW_POSES, nominal) and not python_kernels_pay(FEW_POSES + 1, nominal)
    assert not python_kernels_pay(2, calibrated) and not python_kernels_pay(2)


@pytest.fixture
def recorded_store(tmp_path):
    """A store of the two CONFIGS poses with their joints, as record-pose writes them; awkward names included."""
    store = PoseStore(tmp_path / "poses.json")
    for name, q in zip(("café #1", "end\" of line"), CONFIGS):
        pose = DualQuaternion.from_matrix(ur_analytic_ik.ur3.forward_kinematics(*q))
        store.add(Pose.from_dual_quaternion(name, pose, "ur3", joints=q))
    return store


def test_export_urscript_moves_through_the_recorded_joints(tmp_path, run_cli, recorded_store):
    result = run_cli("export-urscript", "-o", "cell.script", "--speed", "0.5", "--loop", "2")
    assert result.returncode == 0, result.stderr
    program = (tmp_path / "cell.script").read_text()
    code = [line.split("#")[0].strip() for line in program.splitlines() if line.split("#")[0].strip()]
    assert code[0] == "def ur3dq_poses():" and code[-1] == "end"
    assert "while ur3dq_loop < 2:" in code
    moves = [line for line in code if line.startswith("movej(")]
    assert len(moves) == 2
    for move, q in zip(moves, CONFIGS):
        joints = [float(x) for x in move[len("movej(["):move.index("]")].split(",")]
        np.testing.assert_allclose(joints, q, atol=1e-9)
        assert "v=0.5" in move
    assert "# 1: caf? #1" in program and '# 2: end" of line' in program
    assert program.isascii()


def test_checks_tables_on_stderr_fit_the_columns_set(run_cli, recorded_store):
    result = run_cli("--json", "check", COLUMNS="80")   # a table on stderr, the JSON on stdout
    assert result.returncode == 0, result.stderr
    assert "Path check" in result.stderr and max(map(len, result.stderr.splitlines())) <= 80, result.stderr


def test_plot_writes_a_png(tmp_path, run_cli, recorded_store):
    result = run_cli("plot", "-o", "path.png")
    assert result.returncode == 0, result.stderr
    image = (tmp_path / "path.png").read_bytes()
    assert image.startswith(b"\x89PNG\r\n\x1a\n") and len(image) > 10_000
    assert_one_line_error(run_cli("plot", "-o", "path.png"), 1, "Overwrite")


def test_unreachable_stored_pose_stops_the_plan_and_changes_nothing(tmp_path, run_in_process):
    (tmp_path / "far.txt").write_text(thesis_lines_of(CONFIGS[:1]) + "1 0 0 0 0 2.0 0 0\n")
    assert run_in_process("poses", "import", "far.txt").returncode == 0
    before = (tmp_path / "poses.json").read_bytes()
    for command in (["run-poses", "--dry-run"], ["export-urscript"], ["plot"]):
        assert_one_line_error(run_in_process(*command), 4, "pose 'far-2' is unreachable on the ur3", "too far")
    assert (tmp_path / "poses.json").read_bytes() == before


def test_record_pose_into_a_missing_directory_fails_before_the_robot(run_in_process):
    # no robot is configured either: the store is checked first, so the error names the directory
    assert_one_line_error(run_in_process("--store", "nowhere/poses.json", "record-pose", "--yes"), 3,
                          "directory nowhere does not exist")


def test_dry_run_plan_reads_speed_in_degrees_with_deg(run_in_process, recorded_store):
    from ur3dq.robot import motion

    result = run_in_process("--deg", "run-poses", "--dry-run", "--speed", 30, "--json")
    assert result.returncode == 0, result.stderr
    plan = json.loads(result.stdout)["plan"]
    assert [step["source"] for step in plan] == ["IK nearest recorded"] * 2
    assert plan[1]["duration"] == pytest.approx(motion.movej_duration(CONFIGS[0], CONFIGS[1], 1.4, math.radians(30)))
    too_far = run_in_process("--deg", "run-poses", "--dry-run", "--max-travel", 30)
    assert_one_line_error(too_far, 4, "more than --max-travel")


@pytest.mark.parametrize("args", [("--host", "127.0.0.99:30002", "status"), ("status", "--host", "127.0.0.1.5"),
                                  ("--host", "127.0.0.1 2", "poses", "list")])
def test_a_host_that_is_no_address_is_a_usage_error_before_anything_is_contacted(run_in_process, args):
    result = run_in_process(*args)
    assert result.returncode == 2 and "is not an IP address or a host name: give it without a port" in result.stderr


def test_a_simulator_address_that_is_no_loopback_address_is_refused_as_such(run_in_process):
    assert_one_line_error(run_in_process("sim", "start", "--address", "127.0.0.1.5"), 4,
                          "--address '127.0.0.1.5': the embedded simulator binds loopback addresses only")
