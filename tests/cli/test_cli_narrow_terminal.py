"""Issue 14 item 8: every table and report of the CLI reads at 80 columns — every line fits, nothing is cut with
an ellipsis, every pose name appears whole, a 6-number vector breaks between its halves or not at all — and
uses the width when there is more."""
import re

import pytest

from cli_support import Terminal, assert_fits_with_every_name_whole
from ur3dq.kinematics import robot_model
from ur3dq.pose import Pose
from ur3dq.store import PoseStore

UR3 = robot_model("ur3")
NAMES = ("pick-above-the-tray-station", "place-station-2", "home")
POSE = ("0.3", "0.1", "0.2", "3.14", "0", "0")
NEAR = ("--near", "0", "-1.57", "1", "-1.57", "-1.57", "0")
# A bracketed 6-number vector broken anywhere but between its halves: a line ending in its 1st, 2nd, 4th or 5th
# number (the 3rd is the break between x y z and the rotation, or between the arm's and the wrist's joints).
BAD_VECTOR_BREAK = re.compile(r"p?\[(?:[^\],]+,){0,1}[^\],]+,\s*│?\s*$|p?\[(?:[^\],]+,){3,4}[^\],]+,\s*│?\s*$", re.M)


def joints(index):
    return [0.2 * index, -1.2, 1.0 + 0.1 * index, -1.4, -1.57, 0.3 * index]


@pytest.fixture
def store(tmp_path):
    poses = PoseStore(tmp_path / "poses.json")
    for index, name in enumerate(NAMES):
        poses.add(Pose.from_dual_quaternion(name, UR3.fk(joints(index)), "ur3", joints=joints(index), note="a note"))
    return poses


def assert_reads_at_80(result, names=NAMES):
    assert result.returncode == 0, result.stderr
    for text in (result.stdout, result.stderr):
        assert_fits_with_every_name_whole(text, 80, names if text is result.stdout else ())
        assert not BAD_VECTOR_BREAK.search(text), text


@pytest.mark.parametrize("command", [
    ("run-poses", "--dry-run"), ("--deg", "run-poses", "--dry-run"), ("poses", "list"), ("--deg", "poses", "list"),
    ("check",), ("--deg", "check")])
def test_store_tables_fit_80_columns_with_every_name(run_cli, store, command):
    assert_reads_at_80(run_cli(*command, COLUMNS="80"))


@pytest.mark.parametrize("command", [("fk", "0", "-1.57", "0", "-1.57", "0", "0"),
                                     ("--deg", "fk", "0", "-90", "0", "-90", "0", "0"),
                                     ("ik", *POSE), ("ik", *POSE, *NEAR), ("--deg", "ik", "0.3", "0.1", "0.2", "180",
                                                                          "0", "0"),
                                     ("poses", "show", NAMES[0]), ("--deg", "poses", "show", NAMES[0])])
def test_kinematics_and_pose_reports_fit_80_columns(run_cli, store, command):
    assert_reads_at_80(run_cli(*command, COLUMNS="80"), ())


def test_ik_at_80_columns_shows_every_joint_value_in_4_decimals(run_cli):
    result = run_cli("ik", *POSE, *NEAR, COLUMNS="80")
    assert_reads_at_80(result, ())
    rows = [line.split() for line in result.stdout.splitlines() if re.match(r"^\d+\s+-?\d\.\d{4}\s", line)]
    assert len(rows) == 8, result.stdout
    for row in rows:
        assert all(re.fullmatch(r"-?\d\.\d{4}", value) for value in row[1:7]), row
    assert sum("◀" in row for row in rows) == 1, result.stdout


def test_a_cell_program_lists_and_plans_at_80_columns(run_cli, store):
    assert run_cli("poses", "set", NAMES[1], "--move", "linear", "--speed", "0.1").returncode == 0
    assert run_cli("poses", "add-step", "--after", NAMES[1], "wait", "0.5").returncode == 0
    for command in (("poses", "list"), ("run-poses", "--dry-run")):
        assert_reads_at_80(run_cli(*command, COLUMNS="80"))


def test_a_table_says_which_columns_a_narrow_terminal_left_out(run_cli, store):
    result = run_cli("run-poses", "--dry-run", COLUMNS="80")
    assert "not shown at 80 columns: FK check" in result.stdout, result.stdout
    assert "not shown" not in run_cli("run-poses", "--dry-run", COLUMNS="200").stdout


def test_a_wide_terminal_gets_the_full_numbers(run_cli, store):
    result = run_cli("run-poses", "--dry-run", COLUMNS="200")
    assert "[0.000000, -1.200000, 1.000000, -1.400000, -1.570000, 0.000000]" in result.stdout


def test_robot_reports_fit_80_columns(arm, run_cli, store):
    host = ("--host", arm.host)
    arm.place(joints(0))
    for command in (("status",), ("--deg", "status"), ("record-pose", "--yes", "--name", "recorded-at-80-columns"),
                    ("check",), ("run-poses", NAMES[0], "--yes")):
        assert_reads_at_80(run_cli(*host, *command, COLUMNS="80"), NAMES[:1] if "run-poses" in command else ())


def _command_paths(command, path=()):
    yield path
    for name, sub in getattr(command, "commands", {}).items():
        yield from _command_paths(sub, (*path, name))


def test_every_help_page_fits_80_columns():
    # Help pages are written by hand (examples, exit codes in click's verbatim \b blocks, which click never
    # rewraps): each of them, the group's and every command's, is read here at 80 columns.
    from click.testing import CliRunner

    from ur3dq.cli import cli
    runner = CliRunner()   # in-process: ~40 interpreter start-ups would teach nothing more
    paths = list(_command_paths(cli))
    assert len(paths) > 30   # the tree walked: groups and their commands
    for path in paths:
        result = runner.invoke(cli, [*path, "--help"], env={"COLUMNS": "80"})
        assert result.exit_code == 0, (path, result.output)
        too_wide = [line for line in result.output.splitlines() if len(line) > 80]
        assert not too_wide, (path, too_wide)


def test_a_table_piped_to_a_pager_in_a_terminal_fits_that_terminal(tmp_path):
    """stdout piped (`ur3dq poses list | head`), stderr still the 80-column terminal: the table fits 80 columns."""
    import fcntl
    import os
    import pty
    import shutil
    import struct
    import subprocess
    import termios
    from pathlib import Path

    from cli_support import UR3DQ, cli_env

    shutil.copy(Path(__file__).parents[2] / "poses" / "example-poses.json", tmp_path / "poses.json")
    controller, terminal = pty.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    env = cli_env(tmp_path)
    env.pop("COLUMNS")
    try:
        result = subprocess.run([UR3DQ, "poses", "list"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                                stderr=terminal, text=True, timeout=60)
    finally:
        os.close(terminal)
        os.close(controller)
    assert result.returncode == 0
    assert "demo-4" in result.stdout and max(len(line) for line in result.stdout.splitlines()) <= 80


def test_a_usage_error_wraps_between_words_on_a_terminal(tmp_path):
    terminal = Terminal(tmp_path, "export-urp")
    try:
        terminal.wait_for("Error: export-urp writes")
        terminal.process.wait(20)
        lines = ("Error: export-urp writes" + terminal.text).splitlines()
    finally:
        terminal.close()
    assert terminal.process.returncode == 2
    assert all(len(line) <= 80 for line in lines), lines
    assert "`ur3dq export-urp -o cell.urp`" in " ".join(line.strip() for line in lines), lines
