"""Where a new user goes wrong without a robot: each answer says what was understood and names the way on."""
import shutil
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


@pytest.fixture
def store(tmp_path):
    """The example store (its 'demo-1' has the tool pointing down), in the test's directory."""
    shutil.copy(EXAMPLE, tmp_path / "poses.json")
    return tmp_path / "poses.json"


@pytest.mark.parametrize("z, words", [("50mm", "below"), ("-50mm", "above")])
def test_an_offset_says_where_it_lands_in_the_base_frame(run_in_process, store, z, words):
    result = run_in_process("poses", "offset", "near", "--from", "demo-1", f"--z={z}")
    assert result.returncode == 0, result.stderr
    assert f"Base frame: 50.0 mm {words} 'demo-1'" in result.stdout
    assert all(len(line) <= 80 for line in result.stdout.splitlines())


def test_a_taken_step_name_names_the_ways_on(run_in_process, store):
    assert run_in_process("poses", "offset", "near", "--from", "demo-1", "--z", "-50mm").returncode == 0
    again = run_in_process("poses", "offset", "near", "--from", "demo-1", "--z", "-60mm")
    assert again.returncode == 3 and "choose another name" in again.stderr
    assert "`ur3dq poses rm near`" in again.stderr



@pytest.mark.parametrize("program", ["v1", "v2"])
def test_export_urscript_given_a_file_name_says_to_use_output(run_in_process, store, program):
    if program == "v2":
        assert run_in_process("poses", "add-step", "wait", "1").returncode == 0   # the store becomes a program
    result = run_in_process("export-urscript", "job.script")
    assert result.returncode == 2 and "is a file, not a step name: use -o job.script" in result.stderr
    assert all(len(line) <= 80 for line in result.stderr.splitlines()), result.stderr
    assert run_in_process("export-urscript", "-o", "job.script").returncode == 0
    assert "\ndef ur3dq_" in (store.parent / "job.script").read_text()


def test_the_jog_screen_shows_every_joint_and_a_long_message_whole():
    from ur3dq.cli.jog import HEIGHT, WIDTH, JogScreen, screen_lines

    why = ("J5- not moved: cannot open the RTDE inputs of 127.0.0.2:30004 (input registers 18-22; is another RTDE "
           "client writing them?): end the other ur3dq command (record-pose --teach, run-poses) first")
    joints = [-6.2, -3.1, 3.1, -6.2, -1.7, 6.28]
    lines = screen_lines(JogScreen(message=why), "ur3 at 127.0.0.2", joints, [0.1, -0.2, 0.3, 3.1, 0.0, -3.1],
                         "poses.json")
    assert len(lines) == HEIGHT - 1 and all(len(line) <= WIDTH for line in lines)
    assert lines[6].endswith("J6 +359.82")
    assert " ".join(line for line in lines if line).endswith(why.split()[-1])
    assert " ".join(" ".join(lines).split()).count("end the other ur3dq command") == 1


def test_a_waypoint_speed_in_no_speed_unit_names_both_kinds(run_in_process, store):
    result = run_in_process("poses", "set", "demo-1", "--move", "linear", "--speed", "100mm")
    assert result.returncode == 4 and "--speed: '100mm' is neither a joint speed nor a linear speed" in result.stderr
    assert "60deg/s or 250mm/s" in result.stderr


def test_a_pose_value_in_no_unit_names_a_distance_or_an_angle(run_in_process):
    result = run_in_process("ik", "0.3", "0.1", "0.2", "0", "3.14", "nan")
    assert result.returncode == 4 and "'nan' is neither a distance nor an angle; for example -50mm or 5deg" in \
        result.stderr


@pytest.mark.parametrize("args, way_on", [
    (("poses", "set", "demo1", "--speed", "1deg/s"), "did you mean 'demo-1'?"),
    (("poses", "add-step", "--after", "demo1", "wait", "1"), "did you mean 'demo-1'?"),
    (("poses", "set", "gripper", "--speed", "1deg/s"), "`ur3dq poses list` shows them"),
    (("export-urscript", "--from", "demo1"), "did you mean 'demo-1'?"),
])
def test_a_mistyped_step_name_gets_the_close_one_or_the_list(run_in_process, store, args, way_on):
    assert run_in_process("poses", "add-step", "wait", "1").returncode == 0   # the store becomes a program
    result = run_in_process(*args)
    assert result.returncode in (3, 4) and way_on in result.stderr, result.stderr


@pytest.mark.parametrize("args, refusal", [
    (("poses", "offset", "turned", "--from", "demo-1", "--rz", "5"),
     "--rz 5: a bare number is read in rad, and 5 rad is more than a half turn; type 5deg, or 5rad if"),
    (("poses", "add-step", "wait", "500"),
     "TIME 500: a bare number is read in s, and 500 s is more than a minute; type 500ms, or 500s if"),
])
def test_a_bare_number_far_beyond_the_usual_asks_for_its_unit(run_in_process, store, args, refusal):
    before = store.read_bytes()
    result = run_in_process(*args)
    assert result.returncode == 4 and refusal in result.stderr, result.stderr
    assert store.read_bytes() == before
    with_unit = [*args[:-1], args[-1] + ("rad" if "--rz" in args else "s")]
    assert run_in_process(*with_unit).returncode == 0   # typed with its unit, it is taken as typed


@pytest.mark.parametrize("args, refusal", [
    (("poses", "offset", "down", "--from", "demo-1", "--z", "-50"),   # 50 m is past any offset: no "if meant"
     "--z -50: a bare number is read in m, and -50 m is more than a metre; type -50mm"),
    (("poses", "add-step", "wait-input", "3", "on", "--timeout", "100"),
     "--timeout 100: a bare number is read in s, and 100 s is more than a minute; type 100ms, or 100s if that is "
     "meant"),
    (("poses", "add-step", "wait", "1e300"), "and 1e300 s is more than a minute; the most it takes is 86400 s"),
    (("--deg", "poses", "offset", "turned", "--from", "demo-1", "--rz", "500"),
     "500 ° is more than a half turn; type 500deg if that is meant"),
    (("check", "--margin", "5"), "--margin 5: a bare number is read in m, and 5 m is more than half a metre; "
                                 "type 5mm"),
    (("run-poses", "--dry-run", "--blend", "20"), "--blend 20: a bare number is read in m, and 20 m is more than "
                                                  "half a metre; type 20mm"),
    (("export-urp", "--blend", "0.6", "-o", "cell.urp"), "and 0.6 m is more than half a metre; type 0.6mm, or 0.6m if "
                                                        "that is meant"),
])
def test_a_bare_number_past_the_usual_is_offered_only_what_the_option_takes(run_in_process, store, args, refusal):
    before = store.read_bytes()
    result = run_in_process(*args)
    assert result.returncode == 4 and result.stderr.rstrip().endswith(refusal), result.stderr   # all it offers
    assert store.read_bytes() == before


@pytest.mark.parametrize("args", [("poses", "offset", "turned", "--from", "demo-1", "--rz", "3"),
                                  ("poses", "offset", "down", "--from", "demo-1", "--z", "-0.05"),
                                  ("check", "--margin", "0.02"),
                                  ("--deg", "poses", "offset", "turned", "--from", "demo-1", "--rz", "5"),
                                  ("poses", "add-step", "wait", "60")])
def test_a_bare_number_within_the_usual_is_taken(run_in_process, store, args):
    assert run_in_process(*args).returncode == 0


def test_the_run_questions_summary_wraps_within_80_columns_under_its_own_line():
    from ur3dq.cli.plan_summary import PlanFigures, summary_lines
    from ur3dq.units import Units

    figures = PlanFigures(10, 7, 4, 3, 5.0, 0.611, 0.8, "above-place", "home", "retract-place")
    verdict = "Path check (cell cell.json): clear; closest 106.9 mm to the cell at 'retract-pick'"
    lines = summary_lines(figures, verdict, ["speed of 'retract-place' lowered to 250 mm/s (the ur3's limit)"],
                          Units())
    assert all(len(line) <= 80 for line in lines), lines
    assert "('above-place')" in " ".join(lines) and "'retract-pick'" in " ".join(lines)
    assert all(line.startswith("  ") for line in lines[1:]), lines   # a continued line stays under its own
    assert len(lines) <= 10


def test_an_offset_the_arm_cannot_reach_is_refused_and_adds_nothing(run_in_process, store):
    before = store.read_bytes()
    result = run_in_process("poses", "offset", "far", "--from", "demo-1", "--z", "1000mm")
    assert result.returncode == 4 and "step 'far' (relative waypoint): unreachable on the ur3" in result.stderr
    assert "(nothing added: choose an offset the ur3 reaches from 'demo-1')" in result.stderr
    assert store.read_bytes() == before


@pytest.mark.parametrize("args, shown", [(("--rx", "5deg"), "rx,ry,rz +0.0873,+0,+0 rad"),
                                         (("--rz", "-5deg"), "rx,ry,rz +0,+0,-0.0873 rad"),
                                         (("--deg", "--rz", "-5"), "rx,ry,rz +0,+0,-5 °")])
def test_an_offsets_turn_is_shown_about_each_axis_with_its_sign(run_in_process, store, args, shown):
    result = run_in_process("poses", "offset", "turned", "--from", "demo-1", *args)
    assert result.returncode == 0, result.stderr
    assert f"tool {shown}." in result.stdout
