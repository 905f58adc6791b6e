"""What a cell program's plan tells the technician beyond the clamps: a blend they set that the plan does not use
(and why), and how long the program takes, its waits included."""
import json
import shutil
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


@pytest.fixture
def program(tmp_path, run_in_process):
    """The example store (demo-1 .. demo-4) made a cell program by a digital output after demo-2."""
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    added = run_in_process("poses", "add-step", "--after", "demo-2", "digital-out", "3", "on")
    assert added.returncode == 0, added.stderr
    return tmp_path / "poses.json"


def dry_run_json(run_in_process, *args):
    result = run_in_process("run-poses", "--dry-run", "--json", *args)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def test_a_blend_the_plan_drops_is_a_warning_naming_the_step_and_why(run_in_process, program):
    for name in ("demo-2", "demo-3", "demo-4"):
        assert run_in_process("poses", "set", name, "--blend", "20mm").returncode == 0
    planned = dry_run_json(run_in_process)
    assert [step["blend"] for step in planned["plan"] if step["type"] == "joint"] == [0.0, 0.0, 0.02, 0.0]
    dropped = [line for line in planned["warnings"] if "not used" in line]
    assert dropped == [
        "'demo-2': blend 20 mm not used, the digital-out step 'digital-out-1' follows: the action happens at the "
        "waypoint, so the arm stops there first",
        "'demo-4': blend 20 mm not used, it is the last waypoint of the plan: the arm stops there"]
    shown = run_in_process("run-poses", "--dry-run")
    for line in dropped:
        assert line in shown.stderr, shown.stderr
    part = dry_run_json(run_in_process, "--to", "demo-3")   # demo-3 ends this part: its blend goes too
    assert "'demo-3': blend 20 mm not used, it is the last waypoint of the plan: the arm stops there" in \
        part["warnings"]
    script = run_in_process("export-urscript", "-o", "-")
    assert script.returncode == 0 and [line for line in dropped if f"Warning: {line}" in script.stderr] == dropped


def test_a_run_wide_blend_dropped_where_the_arm_must_stop_is_no_warning(run_in_process, program):
    planned = dry_run_json(run_in_process, "--blend", "10mm")
    assert not [line for line in planned["warnings"] if "not used" in line], planned["warnings"]


def test_waits_count_in_the_plan_s_time_and_json(run_in_process, program):
    from ur3dq.cli.plan_summary import program_figures, summary_lines
    from ur3dq.kinematics import robot_model
    from ur3dq.program.plan import plan_program
    from ur3dq.store import PoseStore
    from ur3dq.units import Units

    assert run_in_process("poses", "add-step", "--after", "demo-3", "wait", "30").returncode == 0
    assert run_in_process("poses", "add-step", "--after", "demo-1", "wait-input", "2", "on", "--timeout",
                          "10").returncode == 0
    planned = {step["step"]: step for step in dry_run_json(run_in_process)["plan"]}
    assert planned["wait-1"]["duration"] == 30.0
    assert planned["wait-input-1"]["duration"] is None and planned["wait-input-1"]["timeout"] == 10.0

    steps = PoseStore(program).load_program()   # planned from a known start, as run-poses plans on the arm
    plan = plan_program(robot_model("ur3"), steps, steps[0].pose.joints)
    moving = sum(p.duration for p in plan if p.joints is not None)
    figures = program_figures(plan)
    assert figures.seconds == pytest.approx(moving + 30.0) and figures.input_wait_limit == 10.0
    text = " ".join(line.strip() for line in summary_lines(figures, "Path check (no cell file): clear", [], Units()))
    assert f"about {moving + 30.0:.1f} s at 100 % (30 s of it waits), plus up to 10 s waiting for inputs" in text

