"""The CLI's small pure pieces: display text, exit codes, speed clamping, URScript export, plot geometry, sim state."""
import logging
import math
import os

import numpy as np
import pytest

from ur3dq.cli import display
from ur3dq.cli.app import Cancelled, exit_code_for, one_line, quiet_client_libraries
from ur3dq.cli.background_simulator import process_is_simulator, read_state, state_directory
from ur3dq.cli.options import clamp_to_model
from ur3dq.errors import (
    ConnectionLostError,
    JointLimitError,
    ProtectiveStopError,
    RobotConnectionError,
    SafetyCheckError,
    StoreError,
    UnreachablePoseError,
    add_note,
)
from ur3dq.kinematics import robot_model
from ur3dq.plot import arm_points
from ur3dq.pose import Pose
from ur3dq.replay import plan_replay, replay_script
from ur3dq.units import ANGULAR_SPEED, Units

UR3 = robot_model("ur3")


DEG = Units(angle="deg")


def test_angles_in_degrees_or_radians():
    assert display.angle_text(math.pi / 2, DEG) == "90.000°"
    assert display.angle_text(math.pi / 2, Units()) == "1.570796"
    assert display.angles_text([0, -math.pi], DEG) == "[0.000°, -180.000°]"
    assert display.pose_vector_text([0.1, 0.2, 0.3, 0, 0, math.pi], DEG) == \
        "p[0.100000, 0.200000, 0.300000, 0.000°, 0.000°, 180.000°]"
    assert display.pose_vector_text([0.1, 0.2, 0.3, 0, 0, math.pi], Units("deg", "mm")) == \
        "p[100.000, 200.000, 300.000, 0.000°, 0.000°, 180.000°]"
    assert display.pose_label("TCP pose", Units("deg", "mm")) == "TCP pose (mm, °)"
    assert display.coefficients_text(range(8)) == ("[0.000000000 1.000000000 2.000000000 3.000000000 | 4.000000000 "
                                                  "5.000000000 6.000000000 7.000000000]")
    assert display.distance_text(0.0015, math.radians(2)) == "1.500 mm / 2.000°"


@pytest.mark.parametrize("error, code", [
    (StoreError("x"), 3), (UnreachablePoseError("x"), 4), (JointLimitError("x"), 4), (SafetyCheckError("x"), 4),
    (ValueError("x"), 4), (RobotConnectionError("x"), 5), (ProtectiveStopError("x"), 6),
    (ConnectionLostError("x"), 6), (Cancelled("x"), 1), (FileNotFoundError("x"), 3), (RuntimeError("x"), 70),
])
def test_each_error_kind_has_its_exit_code(error, code):
    assert exit_code_for(error) == code


def test_one_line_joins_lines_and_notes():
    error = RuntimeError("first\nsecond")
    add_note(error, "stopj also failed")   # errors.add_note: BaseException.add_note is Python 3.11's
    assert one_line(error) == "first second stopj also failed"


def test_client_library_warnings_are_quiet_unless_debugging():
    quiet_client_libraries(debug=False)
    assert not logging.getLogger("ursecmon").isEnabledFor(logging.WARNING)
    assert logging.getLogger("urx").isEnabledFor(logging.ERROR)
    quiet_client_libraries(debug=True)  # back to the default: the root logger's level decides
    assert logging.getLogger("ursecmon").isEnabledFor(logging.WARNING)


def test_clamp_to_model():
    assert clamp_to_model(0.5, UR3.max_joint_speed, "--speed", ANGULAR_SPEED, Units()) == (0.5, False)
    assert clamp_to_model(10.0, UR3.max_joint_speed, "--speed", ANGULAR_SPEED, Units()) == \
        (pytest.approx(math.pi), True)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match=r"--speed must be in \[0 rad/s, 3.1416 rad/s\]"):
            clamp_to_model(bad, UR3.max_joint_speed, "--speed", ANGULAR_SPEED, Units())
    with pytest.raises(ValueError, match=r"--speed must be in \[0 °/s, 180 °/s\]"):
        clamp_to_model(-1.0, UR3.max_joint_speed, "--speed", ANGULAR_SPEED, DEG)


def two_step_plan():
    """A plan of two UR3 poses (joints A, B)."""
    poses = [Pose.from_dual_quaternion(name, UR3.fk(q), "ur3", joints=q)
             for name, q in (("a", [0.0, -1.2, 1.0, -1.4, -1.57, 0.0]), ("b", [0.8, -1.0, 1.3, -1.9, -1.57, 0.5]))]
    return plan_replay(UR3, poses, None)


def test_replay_script_blends_only_between_poses():
    program = replay_script(two_step_plan(), a=1.4, v=1.05, blend=0.02, tcp_offset=[0, 0, 0.1, 0, 0, 0],
                             header=["made\nby test"])
    lines = program.splitlines()
    assert lines[0] == "# made?by test" and lines[1] == "def ur3dq_poses():" and lines[-1] == "end"
    assert lines[2] == "  set_tcp(p[0.0, 0.0, 0.1, 0.0, 0.0, 0.0])"
    moves = [line for line in lines if "movej(" in line]
    assert moves[0].endswith("r=0.02)") and moves[1].endswith("r=0.0)")
    looped = replay_script(two_step_plan(), 1.4, 1.05, loops=3)
    assert "  while ur3dq_loop < 3:" in looped and looped.count("movej(") == 2


def test_replay_script_refuses_bad_arguments():
    with pytest.raises(ValueError, match="at least one pose"):
        replay_script([], 1.4, 1.05)
    with pytest.raises(ValueError, match="loops"):
        replay_script(two_step_plan(), 1.4, 1.05, loops=0)
    with pytest.raises(ValueError, match="identifier"):
        replay_script(two_step_plan(), 1.4, 1.05, program_name="bad name")


def test_arm_points_run_from_the_base_to_the_tcp():
    q = [0.3, -1.0, 1.2, -1.5, -1.4, 0.2]
    tool = UR3.with_tcp([0, 0, 0.2, 0, 0, 0])
    points = arm_points(tool, q)
    np.testing.assert_allclose(points[0], 0.0)
    np.testing.assert_allclose(points[1], [0, 0, 0.1519], atol=1e-12)
    np.testing.assert_allclose(points[-1], tool.fk(q).translation, atol=1e-12)


def test_state_directory_precedence(monkeypatch, tmp_path):
    monkeypatch.setenv("UR3DQ_STATE_DIR", str(tmp_path / "explicit"))
    assert state_directory() == tmp_path / "explicit"
    monkeypatch.delenv("UR3DQ_STATE_DIR")
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg"))
    assert state_directory() == tmp_path / "xdg" / "ur3dq"


def test_a_stale_state_file_is_no_simulator(tmp_path):
    assert not process_is_simulator(os.getpid())  # pytest is not sim_ursim
    (tmp_path / "sim.json").write_text(f'{{"pid": {os.getpid()}, "host": "127.0.0.9"}}')
    assert read_state(tmp_path) is None
    (tmp_path / "sim.json").write_text("not json")
    assert read_state(tmp_path) is None
    assert read_state(tmp_path / "missing") is None


def test_counts_take_the_right_number():
    assert display.count_text(1, "pose") == "1 pose"   # "Recorded 1 poses" (issue 14 item 12)
    assert display.count_text(0, "pose") == "0 poses"
    assert display.count_text(2, "pose") == "2 poses"


@pytest.mark.parametrize("line, shown", [
    ("RTDEReceiveInterface boost system Exception: (asio.misc:2) End of file", "dropped"),
    ("RTDEControlInterface: Lost connection to robot...", "dropped"),
    ("RTDEIOInterface: realtime kernel not found, consider using a realtime kernel for better performance", None),
    ("Reconnecting...", None),
    ("Warning! isInRemoteControl() function is not supported on the dashboard server", None),
    ("Error: pose store unreadable", "Error: pose store unreadable"),  # not ur_rtde's: passes unchanged
    ("a line of a user's own tool", "a line of a user's own tool"),
])
def test_ur_rtde_console_lines_become_ur3dq_words_and_others_pass(line, shown):
    from ur3dq.cli.library_output import DROPPED_NOTE, translated

    assert translated(line) == (DROPPED_NOTE if shown == "dropped" else shown)


def test_a_margins_table_of_many_moves_shows_the_ones_that_matter():
    """More than MAX_MARGIN_ROWS moves: the table keeps each check's smallest margin and every failed move, and
    says how many it shows (a 10⁵-row table is unreadable and takes rich a minute)."""
    from rich.console import Console

    from ur3dq.cli.path_report import MAX_MARGIN_ROWS, margins_table
    from ur3dq.pathcheck import PathPlan, PathSegment, check_path

    model = robot_model("ur3")
    home = np.array([0.0, -1.5, 1.2, -1.5, -1.57, 0.0])
    moves = [PathSegment(f"m{i}", target_joints=home + [0.01 * (i % 7), 0, 0.005 * (i % 3), 0, 0, 0])
             for i in range(MAX_MARGIN_ROWS + 50)]
    result = check_path(model, PathPlan(home, moves))
    console = Console(width=200, record=True)
    console.print(margins_table(result, "margins", 200))
    text = console.export_text()
    rows = [line for line in text.splitlines() if line.startswith("│ m")]
    assert 0 < len(rows) <= len(result.steps[0].margins), text
    assert f"of {MAX_MARGIN_ROWS + 50} moves shown" in text
    for check in result.steps[0].margins:   # the move with each check's smallest margin is among the rows
        worst = min(result.steps, key=lambda step: step.margins[check]).name
        assert any(row.startswith(f"│ {worst} ") for row in rows), (check, worst)
