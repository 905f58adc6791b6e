"""Issue 14 item 8 (part): the replay plan and `poses list` read at 80 columns — every line fits, every pose name
appears whole — and use the width when there is more."""
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

UR3 = robot_model("ur3")
NAMES = ("pick-above-the-tray", "place-station-2", "home")


@pytest.fixture
def store(tmp_path):
    poses = PoseStore(tmp_path / "poses.json")
    for index, name in enumerate(NAMES):
        q = [0.2 * index, -1.2, 1.0 + 0.1 * index, -1.4, -1.57, 0.3 * index]
        poses.add(Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=q, note="a note"))
    return poses


@pytest.mark.parametrize("command", [("run-poses", "--dry-run"), ("--deg", "run-poses", "--dry-run"),
                                     ("poses", "list"), ("--deg", "poses", "list")])
def test_every_line_fits_80_columns_and_every_name_appears(run_cli, store, command):
    result = run_cli(*command, COLUMNS="80")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    too_long = [line for line in lines if len(line.rstrip()) > 80]
    assert not too_long, "\n".join(too_long)
    for name in NAMES:
        assert any(name in line for line in lines), (name, result.stdout)


def test_a_wide_terminal_gets_the_full_numbers(run_cli, store):
    result = run_cli("run-poses", "--dry-run", COLUMNS="200")
    assert "[0.000000, -1.200000, 1.000000, -1.400000, -1.570000, 0.000000]" in result.stdout
