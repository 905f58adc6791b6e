"""A store whose recorded joints disagree with their pose: each command that reads it says so, one line per pose."""
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

UR3 = robot_model("ur3")
PICK = (0.0, -1.2, 1.0, -1.4, -1.57, 0.0)
PLACE = (0.8, -1.0, 1.3, -1.9, -1.57, 0.5)
# joints 0.3 rad off their pose on the base; joints 1 mm and 0.02° off it (a calibrated arm's own deviation)
EDITED = (1.1, -1.0, 1.3, -1.9, -1.57, 0.5)   # PLACE with the base 0.3 rad further
NEARLY = (0.0003, -1.2, 1.0, -1.4, -1.57, 0.0)


@pytest.fixture
def edited_store(tmp_path):
    store = PoseStore(tmp_path / "poses.json")
    store.add(Pose.from_dual_quaternion("pick", UR3.fk(PICK), "ur3", joints=PICK))
    store.add(Pose.from_dual_quaternion("place-by-hand", UR3.fk(PLACE), "ur3", joints=EDITED))
    store.add(Pose.from_dual_quaternion("nearly", UR3.fk(PICK), "ur3", joints=NEARLY))
    store.add(Pose.from_dual_quaternion("imported", UR3.fk(PLACE), "ur3"))
    return store


@pytest.mark.parametrize("command", [("poses", "list"), ("check",), ("run-poses", "--dry-run")],
                         ids=["poses-list", "check", "run-poses-dry-run"])
def test_each_command_names_the_pose_whose_joints_are_elsewhere(run_cli, edited_store, command):
    result = run_cli(*command)
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1, result.stderr
    assert warnings[0].startswith("warning: pose 'place-by-hand': joints ")
    assert "off its pose; re-record it" in warnings[0]
    assert len(warnings[0]) <= 80
    assert "warning" not in result.stdout


def test_the_warning_says_how_far(edited_store):
    from ur3dq.cli.display import recorded_joints_warnings

    (line,) = recorded_joints_warnings(edited_store.load())
    distance, angle = line.split(": joints ")[1].split(" off")[0].split(", ")
    assert distance.endswith(" mm") and float(distance[:-3]) > 20
    assert angle == "17.2 °"   # the base turned 0.3 rad


@pytest.mark.parametrize("command", [("poses", "list"), ("run-poses", "--dry-run")], ids=["poses-list", "run-poses"])
def test_a_cell_program_says_so_too(run_cli, edited_store, command):
    assert run_cli("poses", "set", "pick", "--move", "linear").returncode == 0   # the store becomes a program
    result = run_cli(*command)
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and warnings[0].startswith("warning: pose 'place-by-hand': joints "), result.stderr
