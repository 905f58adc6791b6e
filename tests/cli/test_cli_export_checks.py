"""The exports are runs that have not started: export-urscript and export-urp plan a cell program as run-poses
plans it (speeds lowered to the model's limits, with the same warning lines) and refuse a program the path check
refuses, with the check's own one-line error and exit code; check and plot measure a blend the same way."""
import json
import re
import shutil
from pathlib import Path

import pytest

from cli_support import assert_one_line_error

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


@pytest.fixture
def program(tmp_path, run_in_process):
    """The example store as a cell program: 'above' 50 mm (tool z) off demo-1, just after it."""
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    added = run_in_process("poses", "offset", "above", "--from", "demo-1", "--z", "50mm", "--after", "demo-1")
    assert added.returncode == 0, added.stderr
    return tmp_path / "poses.json"


def error_line(result):
    return [line for line in result.stderr.splitlines() if line.startswith("Error: ")][-1]


def test_exports_lower_speeds_as_run_poses_does_and_say_so(run_in_process, program, tmp_path):
    fast = ("--speed", "100", "--acceleration", "1e6")
    dry = run_in_process("run-poses", "--dry-run", "--json", *fast)
    assert dry.returncode == 0, dry.stderr
    planned = json.loads(dry.stdout)
    lowered = planned["warnings"]
    assert "'above': speed lowered to 3.1416 rad/s, acceleration lowered to 40 rad/s² (joint move limit)" in lowered

    script = run_in_process("export-urscript", "-o", "-", *fast)
    assert script.returncode == 0, script.stderr
    assert [f"Warning: {line}" for line in lowered] == script.stderr.splitlines()
    moves = re.findall(r"movej\(\[[^]]*\], a=([\d.e+-]+), v=([\d.e+-]+)", script.stdout)
    assert [(float(a), float(v)) for a, v in moves] == [(step["acceleration"], step["speed"])
                                                        for step in planned["plan"]]

    urp = run_in_process("--json", "export-urp", "-o", "fast.urp", "--yes", *fast)
    assert urp.returncode == 0, urp.stderr
    assert json.loads(urp.stdout)["warnings"] == lowered
    assert [f"Warning: {line}" for line in lowered] == urp.stderr.splitlines()
    text = (tmp_path / "fast.urp").read_text()
    # the waypoints set no speed of their own: they take their Move's, which must be what the plan lowered it to
    moves = re.findall(r'<Move motionType="MoveJ" speed="([^"]+)" acceleration="([^"]+)"', text)
    assert [(float(v), float(a)) for v, a in moves] == [(planned["plan"][0]["speed"],
                                                          planned["plan"][0]["acceleration"])]
    assert moves[0][0].startswith("3.14159") and moves[0][1] == "40.0"
    assert "<motionParameters/>" in text


def test_exports_refuse_a_program_the_path_check_refuses_with_its_error(run_in_process, program, tmp_path):
    assert run_in_process("poses", "set", "above", "--blend", "40mm").returncode == 0
    checked = run_in_process("check")
    assert_one_line_error(checked, 4, "blend radius 40 mm is more than half of a neighbouring move")
    for args in (("export-urscript", "-o", "-"), ("export-urscript", "-o", "cell.script"),
                 ("export-urp", "-o", "cell.urp")):
        refused = run_in_process(*args)
        assert_one_line_error(refused, 4)
        assert error_line(refused) == error_line(checked), args
        assert refused.stdout == ""
    assert not (tmp_path / "cell.script").exists() and not (tmp_path / "cell.urp").exists()


def test_exports_check_the_path_in_the_cell_they_are_given(run_in_process, program, tmp_path):
    (tmp_path / "cell.json").write_text('{"floor": {"z": 0.3}}')   # above most of the poses
    checked = run_in_process("check", "--cell", "cell.json")
    assert checked.returncode == 4
    for command in ("export-urscript", "export-urp"):
        refused = run_in_process(command, "-o", f"out.{command}", "--cell", "cell.json")
        assert_one_line_error(refused, 4, "path check:")
        assert error_line(refused) == error_line(checked)
        assert run_in_process(command, "-o", f"out.{command}").returncode == 0   # no cell, nothing in the way


def test_export_urscript_of_stored_poses_checks_their_replay_in_the_cell(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "poses.json")   # version 1: poses replayed with movej
    (tmp_path / "cell.json").write_text('{"floor": {"z": 0.3}}')
    checked = run_in_process("check", "--cell", "cell.json")
    refused = run_in_process("export-urscript", "-o", "-", "--cell", "cell.json")
    assert_one_line_error(refused, 4, "path check:")
    assert error_line(refused) == error_line(checked) and refused.stdout == ""
    assert run_in_process("export-urscript", "-o", "-").returncode == 0


def test_check_and_plot_measure_the_blend_of_the_first_waypoint_against_the_move_after_it(run_in_process, program):
    """Without a robot the path starts at the first waypoint: the move into it is unknown, not 0 mm long."""
    assert run_in_process("poses", "set", "above", "--blend", "40mm").returncode == 0
    assert run_in_process("poses", "move", "above", "--before", "demo-1").returncode == 0
    checked = run_in_process("check")
    assert_one_line_error(checked, 4, "blend radius 40 mm is more than half of a neighbouring move (50 mm of TCP "
                                      "travel)")
    plotted = run_in_process("plot", "-o", "path.png")
    assert "blend radius 40 mm is more than half of a neighbouring move (50 mm of TCP travel)" in plotted.stdout
    assert run_in_process("poses", "set", "above", "--blend", "20mm").returncode == 0
    assert run_in_process("check").returncode == 0
