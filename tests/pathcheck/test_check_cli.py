"""`ur3dq check` on a stored program, in real subprocesses: the margins table, the one-line refusal with exit 4,
--json, the cell file from --cell and from UR3DQ_CELL, and bad cell files."""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

UR3DQ = str(Path(sys.executable).with_name("ur3dq"))
UR3 = robot_model("ur3")
# Two poses with the tool down, the base turning 90° between them: the sweep passes over x > 0, y ≈ 0.
JOINTS = {"left": [-0.7854, -1.3, 1.3, -1.5708, -1.5708, 0.0], "right": [0.7854, -1.3, 1.3, -1.5708, -1.5708, 0.0]}


@pytest.fixture
def run(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    for name, q in JOINTS.items():
        store.add(Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=tuple(q)))

    def run_check(*args, command="check", **env):
        environment = {k: v for k, v in os.environ.items() if not k.startswith("UR3DQ_")}
        environment.update(UR3DQ_STATE_DIR=str(tmp_path / "state"), UR3DQ_STORE=str(tmp_path / "poses.json"),
                           COLUMNS="200")  # a wide terminal: the full headers
        environment.update(env)
        return subprocess.run([UR3DQ, command, *map(str, args)], cwd=tmp_path, env=environment,
                              capture_output=True, text=True, timeout=60)

    return run_check


def box_under_the_sweep(tmp_path, name="cell.json"):
    """A box where the tool passes halfway through the sweep (θ1 = 0), far from both stored poses."""
    middle = np.array(JOINTS["left"])
    middle[0] = 0.0
    centre = UR3.fk(middle).translation
    path = tmp_path / name
    path.write_text(json.dumps({"floor": {"z": 0.0}, "margin": 0.01,
                                "boxes": [{"name": "fixture", "min": list(centre - 0.03),
                                           "max": list(centre + 0.03)}]}))
    return path


def test_check_passes_without_a_cell_and_prints_each_moves_margins(run):
    result = run()
    assert result.returncode == 0, result.stderr
    assert "left" in result.stdout and "right" in result.stdout and "self mm" in result.stdout
    assert "path clear: 2 moves" in result.stdout


def test_check_refuses_a_sweep_through_a_box_with_exit_4_and_one_line(run, tmp_path):
    result = run("--cell", box_under_the_sweep(tmp_path))
    assert result.returncode == 4, (result.stdout, result.stderr)
    errors = [line for line in result.stderr.splitlines() if line.startswith("Error: ")]
    assert len(errors) == 1
    assert "step 'right' at" in errors[0] and 'keep-out box "fixture"' in errors[0] and "TCP" in errors[0]


def test_the_cell_comes_from_UR3DQ_CELL_and_json_carries_the_problems(run, tmp_path):
    result = run("--json", UR3DQ_CELL=str(box_under_the_sweep(tmp_path)))
    assert result.returncode == 4
    document = json.loads(result.stdout)
    assert document["ok"] is False
    problem = document["problems"][0]
    assert problem["step"] == "right" and problem["check"] == "cell" and 0.2 < problem["fraction"] < 0.8
    assert [step["name"] for step in document["steps"]] == ["left", "right"]


def test_a_linear_check_reports_the_singularity_margins(run):
    result = run("--move", "linear", "--speed", "0.1", "--json")
    assert result.returncode == 0, result.stderr
    margins = json.loads(result.stdout)["steps"][1]["margins"]
    assert {"wrist", "elbow", "shoulder", "joint_speed"} <= set(margins)


@pytest.mark.parametrize("content, code, fragment", [
    ("{not json", 3, "not valid JSON"),
    ('{"boxes": [{"name": "b", "min": [0, 0, 1], "max": [1, 1, 0]}]}', 4, "every min must be below its max"),
    ('{"walls": []}', 4, "unknown key 'walls'"),
    ('{"boxes": [{"name": "caf\xe9", "min": [0, 0, 0], "max": [1, 1, 1]}]}'.encode("latin-1"), 3,
     ":1: not UTF-8 text (byte 0xe9 at offset 24)"),
    ('{"boxes":\n' + "[" * 100_000, 3, ":2: JSON nested deeper than 20 levels"),
    ('{"margin": 1' + "0" * 5000 + "}", 3, "not valid JSON"),
    (b"{}" + b" " * (1024 * 1024), 3, "larger than 1024 KiB"),
])
def test_a_bad_cell_file_is_one_line_naming_the_file(run, tmp_path, content, code, fragment):
    if isinstance(content, bytes):
        (tmp_path / "bad.json").write_bytes(content)
    else:
        (tmp_path / "bad.json").write_text(content)
    result = run("--cell", "bad.json")
    assert result.returncode == code
    assert result.stderr.strip().count("\n") == 0 and "bad.json" in result.stderr and fragment in result.stderr


def test_a_missing_cell_file_is_refused_with_one_to_start_from(run, tmp_path):
    result = run("--cell", "cell.json")
    assert result.returncode == 3 and result.stderr.strip().count("\n") == 0, result.stderr
    assert "cell file cell.json: no such file" in result.stderr and "docs/cell-file.md" in result.stderr
    (tmp_path / "cell.json").write_text(result.stderr[result.stderr.index("{"):])   # the example, as printed
    started = run("--cell", "cell.json")
    assert started.returncode == 0, started.stderr
    assert "path clear: 2 moves" in started.stdout


def test_run_poses_refuses_before_moving_when_the_path_check_fails(run, tmp_path):
    cell = box_under_the_sweep(tmp_path)
    result = run("--dry-run", command="run-poses", UR3DQ_CELL=str(cell))
    assert result.returncode == 4, (result.stdout, result.stderr)
    assert result.stderr.startswith("Error: path check: step 'right' at")
    assert 'keep-out box "fixture"' in result.stderr
    assert "Path check: the worst point of each move" in result.stdout and "cell mm" in result.stdout
    clear = run("--dry-run", "--json", command="run-poses")             # no cell: the same plan passes
    assert clear.returncode == 0 and "Path check" in clear.stderr and json.loads(clear.stdout)["plan"]
    looped = run("--dry-run", "--loop", "2", "--cell", cell, command="run-poses")
    assert looped.returncode == 4


def test_plot_draws_the_path_check_and_names_its_worst_sample(run, tmp_path):
    result = run("-o", "path.png", "--cell", box_under_the_sweep(tmp_path), command="plot")
    assert result.returncode == 0, result.stderr
    assert "Path check: step 'right' at" in result.stdout and 'keep-out box "fixture"' in result.stdout
    assert (tmp_path / "path.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    clear = run("-o", "clear.png", command="plot")
    assert clear.returncode == 0 and "Path check: path clear: 2 moves" in clear.stdout


def test_with_a_robot_the_path_starts_at_the_arms_joints(run):
    from sim_ursim.launch import simulator_process

    arm_at = [5.6, -1.3, 1.3, -1.5708, -1.5708, 0.0]   # the base 0.68 rad from its limit, unlike either pose
    with simulator_process(model="ur3", initial_q=arm_at) as simulator:
        result = run("--json", UR3DQ_HOST=simulator.host)
    assert result.returncode == 0, result.stderr
    assert "from the arm's joints" in result.stderr
    steps = json.loads(result.stdout)["steps"]
    assert [step["name"] for step in steps] == ["left", "right"]
    # a real move from the arm's joints to the first pose, not a 0-length one at the first pose
    assert steps[0]["margins"]["joint_limit"] == pytest.approx(2 * math.pi - 5.6, abs=1e-4)
    assert steps[1]["margins"]["joint_limit"] > 4


def test_a_cell_program_is_checked_with_its_own_moves_by_run_poses_and_check(run, tmp_path):
    """A version-2 store (cell program): the joint move through the box is refused by run-poses --dry-run and by
    check, naming the step and the box; the same program passes without the cell."""
    assert run("set", "right", "--speed", "0.5", command="poses").returncode == 0   # the store becomes a program
    cell = box_under_the_sweep(tmp_path)
    for command in ("run-poses", "check"):
        result = run(*(("--dry-run",) if command == "run-poses" else ()), "--cell", cell, command=command)
        assert result.returncode == 4, (command, result.stdout, result.stderr)
        assert "step 'right' at" in result.stderr and 'keep-out box "fixture"' in result.stderr, result.stderr
        assert run(*(("--dry-run",) if command == "run-poses" else ()), command=command).returncode == 0


def test_a_cell_programs_linear_move_through_the_wrist_singularity_is_refused(run, tmp_path):
    """The program's own move type is checked: a linear step whose line crosses θ5 = 0 (the base-joint direction
    at constant orientation: θ1 changes through the line, θ5 = acos(z1·z6) crosses 0) is refused as a line, and
    the same targets as joint moves pass."""
    middle = np.array([0.0, -1.2, 1.5, -1.8, 0.0, 0.5])
    z1 = np.array([np.sin(middle[0]), -np.cos(middle[0]), 0.0])
    store = PoseStore(tmp_path / "poses.json")
    for name in list(JOINTS):
        store.remove(name)
    for name, offset in (("before", -0.06), ("after", 0.06)):
        pose = DualQuaternion.from_translation(offset * z1) * UR3.fk(middle)
        store.add(Pose.from_dual_quaternion(name, pose, "ur3", joints=tuple(UR3.ik(pose, middle))))
    assert run("--dry-run", command="run-poses").returncode == 0
    assert run("set", "after", "--move", "linear", "--speed", "0.05", command="poses").returncode == 0
    result = run("--dry-run", command="run-poses")
    assert result.returncode == 4, (result.stdout, result.stderr)
    assert "step 'after' at" in result.stderr and "wrist singular" in result.stderr, result.stderr


def box_on_the_line(tmp_path):
    """A box where the straight TCP line between the two stored poses passes, halfway."""
    centre = (UR3.fk(JOINTS["left"]).translation + UR3.fk(JOINTS["right"]).translation) / 2
    path = tmp_path / "line-cell.json"
    path.write_text(json.dumps({"margin": 0.01, "boxes": [{"name": "fixture", "min": list(centre - 0.03),
                                                           "max": list(centre + 0.03)}]}))
    return path


def test_a_failed_check_prints_each_problem_once_with_a_true_hint_and_columns_that_agree(run, tmp_path):
    for move, cell, wrong_hint in (("joint", box_under_the_sweep(tmp_path), "make it a joint move"),
                                   ("linear", box_on_the_line(tmp_path), "use a linear move there")):
        result = run("--cell", cell, "--move", move, COLUMNS="80")
        assert result.returncode == 4, result.stderr
        both = result.stdout + result.stderr
        assert both.count("step 'right' at") == 1, both   # once: in the error line
        assert result.stderr.startswith("Error: path check: step 'right' at") and result.stderr.count("\n") == 1
        assert wrong_hint not in " ".join(both.split()), both
        assert max(len(line) for line in result.stdout.splitlines()) <= 80
        inside = float(result.stderr.split(" mm inside")[0].split()[-1])      # "... capsule 62 mm inside ..."
        row = next(line for line in result.stdout.splitlines() if line.startswith("right "))
        assert float(row.split()[-1]) == pytest.approx(-inside, abs=1.0)   # the cell column: that clearance, in mm
        assert "cell: mm to the nearest obstacle (≥ 10)" in result.stdout


def test_the_wrist_is_said_in_degrees_from_singular(run):
    result = run("--move", "linear", COLUMNS="80")
    assert "wrist°" in result.stdout and "wrist, elbow: ° from singular (≥ 1.1°)" in result.stdout


def test_a_huge_cell_file_is_refused_unread(run, tmp_path):
    with open(tmp_path / "huge.json", "wb") as stream:   # 100 MB that take no disk: a sparse file of zero bytes
        stream.truncate(100 * 1024 * 1024)
    result = run("--cell", "huge.json")
    assert result.returncode == 3 and "huge.json: larger than 1024 KiB" in result.stderr, result.stderr
