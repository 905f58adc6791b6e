"""Cell programs through the CLI (in-process `main` for bad input, real subprocesses otherwise): bad steps are one
line naming the step with the store unchanged, a v1 store plans identically after its upgrade and keeps a backup,
kill -9 during an upgrade loses nothing, user text is shown as typed, tables fit 80 columns, plot leaves no empty
PNG."""
import json
import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from cli_support import assert_fits_with_every_name_whole, assert_one_line_error
from ur3dq.cli.display import print_table
from ur3dq.cli.program_workflow import PLAN_COLUMNS, plan_rows
from ur3dq.kinematics import robot_model
from ur3dq.program.plan import plan_program
from ur3dq.store import PoseStore
from ur3dq.units import Units

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


@pytest.fixture
def v1_store(tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    return tmp_path / "poses.json"


@pytest.mark.parametrize("args, code, fragments", [
    (("poses", "add-step", "digital-out", "9", "on"), 4,
     ["step 'digital-out-1' (digital-out): standard pin 9 is out of range (0..7)"]),
    (("poses", "add-step", "tool-out", "2", "on"), 4, ["step 'tool-out-1' (digital-out): tool pin 2 is out of range"]),
    (("poses", "add-step", "wait", "--", "-1"), 4, ["step 'wait-1' (wait): seconds must be a finite number > 0"]),
    (("poses", "add-step", "wait-input", "3", "on", "--timeout", "nan"), 4, ["--timeout: 'nan' is not a duration"]),
    (("poses", "add-step", "wait-input", "3", "on", "--timeout", "1e6s"), 4, ["step 'wait-input-1' (wait-input)"]),
    (("poses", "add-step", "--after", "nowhere", "wait", "1"), 3, ["no step named 'nowhere'"]),
    (("poses", "set", "demo-1", "--speed", "0"), 4,
     ["step 'demo-1' (waypoint): --speed must be more than 0 rad/s, got 0 rad/s"]),
    (("poses", "set", "demo-1", "--blend", "1e9m"), 4,
     ["step 'demo-1' (waypoint): --blend must be from 0 m to 1 m, got 1e9m"]),
    (("poses", "offset", "up", "--from", "gone", "--z", "0.1"), 4,
     ["step 'up' (relative waypoint): its base waypoint 'gone' is not in the program"]),
    (("poses", "offset", "far", "--from", "demo-1", "--z", "1e6m"), 4, ["step 'far' (relative waypoint): offset"]),
    (("record-pose", "--name", "x", "--move", "linear", "--speed", "0", "--yes"), 4,
     ["waypoint 'x': --speed must be more than 0 m/s, got 0 m/s"]),
    (("record-pose", "--name", "x", "--after", "nowhere", "--yes"), 3, ["no step named 'nowhere'"]),
])
def test_bad_steps_are_one_line_naming_the_step_and_leave_the_store_unchanged(run_in_process, v1_store, args, code,
                                                                             fragments):
    before = v1_store.read_bytes()
    assert_one_line_error(run_in_process(*args), code, *fragments)
    assert v1_store.read_bytes() == before
    assert not v1_store.with_name("poses.json.v1.bak").exists()


def test_unknown_step_type_is_refused(run_in_process, v1_store):
    before = v1_store.read_bytes()
    result = run_in_process("poses", "add-step", "teleport", "1")
    assert result.returncode == 2 and "teleport" in result.stderr
    assert v1_store.read_bytes() == before


def test_removing_a_base_and_a_hand_made_cycle_name_the_relative_step(run_in_process, v1_store):
    assert run_in_process("poses", "offset", "above", "--from", "demo-1", "--z", "-0.05").returncode == 0
    before = v1_store.read_bytes()
    assert_one_line_error(run_in_process("poses", "rm", "demo-1", "--yes"), 4,
                          "step 'above' (relative waypoint): its base waypoint 'demo-1' is not in the program")
    assert v1_store.read_bytes() == before
    document = json.loads(before)
    document["steps"].append({"type": "relative", "name": "loop", "base": "above", "offset": [0] * 6,
                              "frame": "tool"})
    for step in document["steps"]:
        if step["name"] == "above":
            step["base"] = "loop"
    v1_store.write_text(json.dumps(document))
    assert_one_line_error(run_in_process("poses", "list"), 3, "poses.json:1:", "relative waypoints form a cycle")


def test_v1_store_plans_identically_after_its_upgrade_and_keeps_a_backup(run_in_process, v1_store):
    original = v1_store.read_bytes()
    assert run_in_process("poses", "list").returncode == 0 and v1_store.read_bytes() == original
    before = run_in_process("run-poses", "--dry-run", "--json")
    assert before.returncode == 0, before.stderr
    assert run_in_process("poses", "add-step", "wait", "0.5").returncode == 0
    assert v1_store.with_name("poses.json.v1.bak").read_bytes() == original
    assert json.loads(v1_store.read_text())["version"] == 2
    assert run_in_process("poses", "rm", "wait-1", "--yes").returncode == 0
    after = run_in_process("run-poses", "--dry-run", "--json")
    assert after.returncode == 0, after.stderr
    old_joints = np.array([step["joints"] for step in json.loads(before.stdout)["plan"]])
    new_joints = np.array([step["joints"] for step in json.loads(after.stdout)["plan"]])
    # the same IK solution of every pose; the program planner solves them in one batch, whose arithmetic may
    # differ from the per-pose solver's in the last bit
    assert old_joints.shape == (4, 6) and np.max(np.abs(new_joints - old_joints)) < 1e-12


UPGRADER = """
import sys
from ur3dq.program.steps import Wait
from ur3dq.store import PoseStore
store = PoseStore(sys.argv[1])
print("ready", flush=True)
store.update_program(lambda steps: (steps + [Wait("pause", 1.0)], None))
"""


def test_kill_9_during_an_upgrade_loses_nothing(tmp_path):
    rng = random.Random(5)
    original = EXAMPLE.read_bytes()
    names = [pose.name for pose in PoseStore(EXAMPLE).load()]
    outcomes = set()
    for attempt in range(12):
        directory = tmp_path / str(attempt)
        directory.mkdir()
        (directory / "poses.json").write_bytes(original)
        process = subprocess.Popen([sys.executable, "-c", UPGRADER, str(directory / "poses.json")],
                                   stdout=subprocess.PIPE, text=True)
        assert process.stdout.readline().strip() == "ready"
        subprocess.run(["sleep", f"{rng.uniform(0, 0.02):.4f}"])
        process.kill()
        process.wait()
        process.stdout.close()
        store = PoseStore(directory / "poses.json")
        assert [pose.name for pose in store.load()] == names
        backup = directory / "poses.json.v1.bak"
        if store.version() == 2:
            assert backup.read_bytes() == original
            outcomes.add("upgraded")
        else:
            assert (directory / "poses.json").read_bytes() == original
            outcomes.add("old")
    assert outcomes  # each run ends in one of the two states; both are checked above


def test_rich_markup_in_names_notes_and_paths_is_shown_as_typed(run_cli, tmp_path):
    store = tmp_path / "[bold]cell.json"
    shutil.copy(EXAMPLE, store)
    assert run_cli("--store", store, "poses", "rename", "demo-1", "[/]").returncode == 0
    added = run_cli("--store", store, "poses", "add-step", "--name", "[red]say", "message", "[bold red]hi")
    assert added.returncode == 0
    listed = run_cli("--store", store, "poses", "list")
    assert listed.returncode == 0, listed.stderr
    for text in ("[/]", "[red]say", "[bold red]hi", "[bold]cell.json"):
        assert text in listed.stdout
    shown = run_cli("--store", store, "poses", "show", "[/]")
    assert shown.returncode == 0 and "Pose '[/]'" in shown.stdout


def test_plan_table_fits_80_columns_and_keeps_every_name():
    from ur3dq.program.steps import Message, Waypoint

    steps = PoseStore(EXAMPLE).load_program()
    steps = [Waypoint(s.name, s.pose.renamed(s.name), s.motion) for s in steps] + [
        Message("a-very-long-step-name-that-must-wrap-but-never-vanish", "x" * 120)]
    plan = plan_program(robot_model("ur3"), steps)
    console = Console(width=80, record=True)
    print_table(console, "plan", PLAN_COLUMNS, plan_rows(plan, 1, Units()))
    assert_fits_with_every_name_whole(console.export_text(), 80, [step.name for step in steps])


def test_plot_failure_names_the_file_and_leaves_no_empty_png(run_in_process, v1_store, tmp_path):
    assert_one_line_error(run_in_process("plot", "-o", "missing/out.png"), 3, "missing/out.png", "cannot write")
    assert not (tmp_path / "missing").exists()
    (tmp_path / "a-file").write_text("not a directory")
    assert_one_line_error(run_in_process("plot", "-o", "a-file/out.png"), 3, "a-file/out.png", "cannot write")
    assert (tmp_path / "a-file").read_text() == "not a directory"


@pytest.mark.parametrize("items", [[], [{"a": [1, 2], "b": {"c": None}}], [{"x": 1}, {"y": [1, "é"]}],
                                   [{"n": n} for n in range(2500)]])
def test_streamed_json_list_is_exactly_what_emit_json_prints(items, capsys):
    from ur3dq.cli.app import emit_json, emit_json_list

    emit_json({"store": "s", "steps": items})
    whole = capsys.readouterr().out
    emit_json_list({"store": "s"}, "steps", iter(items))
    assert capsys.readouterr().out == whole


def test_markup_in_pose_names_does_not_break_the_replay_plan(run_cli, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    assert run_cli("poses", "rename", "demo-2", "[bold red]x[/]").returncode == 0
    result = run_cli("run-poses", "--dry-run")
    assert result.returncode == 0, result.stderr
    assert "[bold red]x[/]" in result.stdout


def test_the_v1_replay_plan_table_fits_80_columns_with_every_pose_name():
    from ur3dq.cli.display import plan_table
    from ur3dq.replay import plan_replay

    steps = plan_replay(robot_model("ur3"), PoseStore(EXAMPLE).load(), None)
    console = Console(width=80, record=True)
    console.print(plan_table(steps, Units(), "Plan", 80))
    assert_fits_with_every_name_whole(console.export_text(), 80, [step.pose.name for step in steps])


def test_speed_scale_scales_every_step_and_refuses_nonsense(run_in_process, v1_store):
    assert run_in_process("poses", "set", "demo-2", "--move", "linear", "--speed", "0.2").returncode == 0
    full = json.loads(run_in_process("run-poses", "--dry-run", "--json").stdout)["plan"]
    half = json.loads(run_in_process("run-poses", "--dry-run", "--json", "--speed-scale", "0.5").stdout)["plan"]
    assert [step["speed"] for step in half] == pytest.approx([step["speed"] / 2 for step in full])
    assert [step["type"] for step in full] == ["joint", "linear", "joint", "joint"]
    for bad in ("2", "0", "nan"):
        assert_one_line_error(run_in_process("run-poses", "--dry-run", "--speed-scale", bad), 4, "--speed-scale")


def test_a_cell_program_runs_its_path_check_in_the_cell_it_was_given(run_in_process, v1_store, tmp_path):
    (tmp_path / "cell.json").write_text('{"floor": {"z": 0.0}}')
    result = run_in_process("run-poses", "--from", "demo-1", "--dry-run", "--cell", "cell.json")
    assert result.returncode == 0, result.stderr
    assert "Path check: the worst point of each move" in result.stdout and "cell: cell.json" in result.stdout


def test_poses_show_of_a_step_shows_its_fields(run_in_process, v1_store):
    assert run_in_process("poses", "add-step", "wait-input", "2", "off", "--timeout", "4").returncode == 0
    shown = run_in_process("poses", "show", "wait-input-1", "--json")
    assert shown.returncode == 0, shown.stderr
    assert json.loads(shown.stdout)["step"] == {"type": "wait-input", "name": "wait-input-1", "input": "standard",
                                                "pin": 2, "on": False, "timeout": 4.0}
    assert "Step 'wait-input-1'" in run_in_process("poses", "show", "wait-input-1").stdout
    assert "Pose 'demo-1'" in run_in_process("poses", "show", "demo-1").stdout
