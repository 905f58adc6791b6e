"""Issue 10 item 6 and issue 14 items 10, 11: options outside their valid range are refused with the range, joint
values outside the limits with a --deg hint, and `ik --near` marks what would really be sent."""
import math

import numpy as np
import pytest

from cli_support import assert_one_line_error
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

UR3 = robot_model("ur3")


@pytest.fixture
def two_poses(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    for name, q in (("a", [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]), ("b", [0.8, -1.0, 1.3, -1.9, -1.57, 0.5])):
        store.add(Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=q))
    return store


@pytest.mark.parametrize("options, fragment", [
    (("--acceleration", "1e-300"), "--acceleration must be in [0.001 rad/s², "),
    (("--speed", "1e-300"), "--speed must be in [0.001 rad/s, "),
    (("--speed", "250mm/s"), "--speed takes a joint speed"),
    (("--max-travel", "nan"), "--max-travel: 'nan' is not an angle"),
    (("--max-travel", "400deg"), "--max-travel must be an angle in (0, 360°]"),
    (("--blend", "1e9mm"), "--blend must be a radius in [0, 1000 mm]"),   # the waypoint's own bound
])
@pytest.mark.parametrize("command", ["run-poses --dry-run", "export-urscript"])
def test_options_outside_their_range_are_refused_with_the_range(run_in_process, two_poses, command, options,
                                                                fragment):
    result = run_in_process(*command.split(), *options)
    assert_one_line_error(result, 4, fragment)
    assert result.stdout == ""


def test_fk_in_radians_outside_the_limits_suggests_deg(run_in_process):
    assert_one_line_error(run_in_process("fk", "0", "-90", "0", "-90", "0", "0"), 4, "joint 2", "did you mean --deg")
    assert run_in_process("fk", "0", "-90", "0", "-90", "0", "0", "--deg").returncode == 0


def test_ik_near_outside_the_limits_is_refused_without_a_numpy_warning(run_in_process):
    result = run_in_process("ik", "0.3", "0.1", "0.2", "0", "3.14159", "0", "--near", "1e308", "0", "0", "0", "0", "0")
    assert_one_line_error(result, 4, "--near", "outside", "did you mean --deg")
    assert "Warning" not in result.stderr


def test_ik_near_marks_the_row_that_would_be_sent_with_its_travel(run_in_process, monkeypatch):
    monkeypatch.setenv("COLUMNS", "160")   # full joint values in the table, whatever terminal runs the suite
    near = [0.0, -1.5, 1.5, -1.5, -1.5, 6.0]  # wrist 3 near 2π: the solution sent is a +2π variant
    result = run_in_process("ik", "0.3", "0.1", "0.2", "0", "3.14159", "0", "--json", "--near", *map(str, near))
    import json

    chosen = np.array(json.loads(result.stdout)["chosen"])
    table = run_in_process("ik", "0.3", "0.1", "0.2", "0", "3.14159", "0", "--near", *map(str, near)).stdout
    marked = [line for line in table.splitlines() if "◀" in line and "│" in line]
    assert len(marked) == 1
    cells = [cell.strip() for cell in marked[0].split("│") if cell.strip()]
    np.testing.assert_allclose([float(c) for c in cells[1:7]], chosen, atol=1e-6)  # the variant sent, not canonical
    travel = float(cells[8])
    assert travel == pytest.approx(np.max(np.abs(chosen - near)), abs=1e-4)
    assert chosen[5] > math.pi  # the row shown is the +2π variant


def test_global_options_after_the_command_name(run_in_process, two_poses, tmp_path):
    result = run_in_process("fk", "0", "-90", "0", "-90", "0", "0", "--deg", "--model", "ur5e", "--json")
    assert result.returncode == 0, result.stderr
    import json

    assert json.loads(result.stdout)["model"] == "ur5e"
    result = run_in_process("poses", "list", "--store", str(tmp_path / "other.json"))
    assert result.returncode == 0 and "has no poses yet" in result.stdout
