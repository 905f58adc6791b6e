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
