"""`poses import` of another ur3dq store takes its whole cell program: every step as it is (move types, speeds,
blends, relative waypoints, outputs, waits), taken names numbered on with a warning, relative waypoints following."""
import json
import shutil
from pathlib import Path

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


def test_importing_a_cell_program_store_keeps_its_steps_and_motions(run_in_process, tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "other.json")
    for args in (("poses", "rm", "demo-3", "--yes"), ("poses", "rm", "demo-4", "--yes"),
                 ("poses", "set", "demo-2", "--move", "linear", "--speed", "100mm/s", "--blend", "5mm"),
                 ("poses", "offset", "above", "--from", "demo-2", "--z", "-50mm", "--before", "demo-2"),
                 ("poses", "add-step", "digital-out", "3", "on"), ("poses", "add-step", "wait", "1.5")):
        assert run_in_process("--store", "other.json", *args).returncode == 0, args
    other = json.loads(run_in_process("--store", "other.json", "poses", "list", "--json").stdout)["steps"]

    imported = run_in_process("--store", "new.json", "poses", "import", "other.json", "--json")   # into nothing
    assert imported.returncode == 0, imported.stderr
    assert json.loads(imported.stdout)["imported"] == ["demo-1", "above", "demo-2", "digital-out-1", "wait-1"]
    assert json.loads(run_in_process("--store", "new.json", "poses", "list", "--json").stdout)["steps"] == other

    shutil.copy(EXAMPLE, tmp_path / "poses.json")   # demo-1 .. demo-4 taken: numbered on, 'above' follows its base
    appended = run_in_process("poses", "import", "other.json")
    assert appended.returncode == 0, appended.stderr
    assert "Imported 5 steps into poses.json: demo-5, above, demo-6, digital-out-1, wait-1" in appended.stdout
    assert "Warning: the name 'demo-2' is taken; imported as 'demo-6'" in appended.stderr
    steps = json.loads(run_in_process("poses", "list", "--json").stdout)["steps"]
    assert [step["name"] for step in steps] == ["demo-1", "demo-2", "demo-3", "demo-4", "demo-5", "above",
                                                "demo-6", "digital-out-1", "wait-1"]
    by_name = {step["name"]: step for step in steps}
    assert by_name["above"]["base"] == "demo-6"
    assert (by_name["demo-6"]["move"], by_name["demo-6"]["speed"], by_name["demo-6"]["blend"]) == ("linear", 0.1,
                                                                                                   0.005)
    assert by_name["wait-1"]["seconds"] == 1.5 and by_name["digital-out-1"]["pin"] == 3
