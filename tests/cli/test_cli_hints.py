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
    assert result.returncode == 2 and "-o job.script" in result.stderr, result.stderr
    assert run_in_process("export-urscript", "-o", "job.script").returncode == 0
    assert "\ndef ur3dq_" in (store.parent / "job.script").read_text()
