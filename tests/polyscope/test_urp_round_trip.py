"""export-urp then import-urp gives the same program back, for 200 random programs of every step kind; the file is
the same bytes for the same program, and the same again after a round trip."""
import gzip
import os
from pathlib import Path

import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.polyscope.urp_export import export_bytes
from ur3dq.polyscope.urp_file import parse_urp_bytes
from ur3dq.polyscope.urp_import import import_program
from ur3dq.program.steps import RelativeWaypoint, Wait
from ur3dq.store import PoseStore
from ur3dq.store_format import needs_version_2
from urp_programs import as_exported, assert_same_program, plan_of, random_program
from urp_samples import E_SERIES_WAIT_PROGRAM

EXAMPLE = Path(__file__).parents[2] / "poses" / "example-poses.json"


def round_trip(model, steps, replay_joints=False):
    plan = plan_of(model, steps, replay_joints)
    data = export_bytes(plan, steps, "cell", model)
    return plan, data, import_program(parse_urp_bytes(data, "cell.urp"))


# the same 200 programs every run; UR3DQ_HYPOTHESIS=explore (as for the property tests) draws 200 new ones
SEEDS = np.random.default_rng().integers(10_000, 2**32, 200).tolist() \
    if os.environ.get("UR3DQ_HYPOTHESIS") == "explore" else list(range(200))


def test_export_then_import_gives_the_same_program_for_200_random_programs():
    kinds = set()
    for seed in SEEDS:
        model, steps = random_program(seed, "ur5e" if seed % 4 else "ur3")
        plan, data, imported = round_trip(model, steps)
        assert imported.model.name == model.name and not imported.model.calibrated
        assert_same_program(imported.steps, as_exported(plan), seed=seed)
        kinds |= {(step.kind, getattr(getattr(step, "motion", None), "move", None)) for step in steps}
    assert kinds >= {("waypoint", "joint"), ("waypoint", "linear"), ("waypoint", "process"),
                     ("relative waypoint", "linear"), ("digital-out", None), ("analog-out", None), ("wait", None),
                     ("wait-input", None), ("message", None), ("comment", None)}


@pytest.mark.parametrize("seed", range(10))
def test_the_same_program_gives_the_same_bytes_also_after_a_round_trip(seed):
    model, steps = random_program(1000 + seed, "ur10e" if seed % 2 else "ur3")
    plan, data, imported = round_trip(model, steps)
    assert data[:2] == b"\x1f\x8b" if model.name.endswith("e") else data.startswith(b"<URProgram ")
    assert export_bytes(plan_of(model, steps), steps, "cell", model) == data
    # the imported program's joints are the planned ones: written again as they are, the file is the same, but
    # for a relative waypoint's joints, solved again from its base's pose, which round-trips within 1e-16
    again = export_bytes(plan_of(model, imported.steps, True), imported.steps, "cell", model)
    if not any(isinstance(step, RelativeWaypoint) for step in steps):
        assert again == data
    first, second = (text.splitlines() for text in map(_xml, (data, again)))
    assert len(first) == len(second)
    for line, other in zip(first, second):
        if line != other:
            assert "<JointAngles" in line
            assert np.allclose(_numbers(line), _numbers(other), rtol=0, atol=1e-12)


def _xml(data):
    return (gzip.decompress(data) if data[:2] == b"\x1f\x8b" else data).decode()


def _numbers(line):
    return [float(v) for v in line.split('"')[1].split(",")]


def test_a_program_of_default_waypoints_comes_back_as_a_version_1_program():
    steps = PoseStore(EXAMPLE).load_program()
    _, _, imported = round_trip(robot_model("ur3"), steps)
    assert not needs_version_2(imported.steps)
    assert [s.pose.note for s in imported.steps] == [s.pose.note for s in steps]


@pytest.mark.parametrize("model_name", ["ur3", "ur5e"])
def test_the_layout_follows_polyscope_s_files(model_name):
    """The header, kinematics and Wait node are written as in URCL's wait_program.urp, line for line."""
    steps = [Wait("Wait 0.01", 0.01)]
    data = export_bytes(plan_of(robot_model(model_name), steps), steps, "wait_program", robot_model(model_name))
    text = (data if model_name == "ur3" else gzip.decompress(data)).decode()
    version = "3.15.8.106339" if model_name == "ur3" else "5.12.4.1101661"
    assert text.splitlines()[0] == (
        f'<URProgram name="wait_program" installation="default" installationRelativePath="default" '
        f'directory="/programs" createdIn="{version}" lastSavedIn="{version}">')
    saved = E_SERIES_WAIT_PROGRAM.replace('runOnlyOnce="false"', 'runOnlyOnce="true"')   # ur3dq runs once
    assert text.splitlines()[6:] == saved.splitlines()[6:]


SMALL_DELTAS = {"a": [0.0002, -0.0003, 0.0004, 0.0001, -0.0001, 0.0], "d": [0.0003, 0.0, 0.0, -0.0002, 0.0001, 0.0002],
                "alpha": [0.0005, -0.0003, 0.0002, 0.0006, -0.0004, 0.0],
                "theta": [0.0, 0.0004, -0.0002, 0.0003, 0.0, -0.0001]}


@pytest.mark.parametrize("model_name, calibration", [("ur5e", "small"), ("ur10e", "factory"), ("ur3", "factory")])
def test_a_calibrated_arm_s_program_carries_its_calibration_and_reads_back_on_it(model_name, calibration):
    """The file holds the DH table of the arm it was planned on (a factory table: hundreds of metres in cancelling
    offsets), the same bytes each time; the import finds that arm's model with that very table, and the program."""
    from sim_ursim.calibration import factory_calibration

    deltas = SMALL_DELTAS if calibration == "small" else factory_calibration(_rows(robot_model(model_name).dh), 5)
    model = robot_model(model_name, deltas)
    _, steps = random_program(2000 + len(model_name), model_name)
    plan, data, imported = round_trip(model, steps)
    assert export_bytes(plan_of(model, steps), steps, "cell", model) == data
    assert 'status="LINEARIZED"' in _xml(data)
    assert imported.model.name == model_name and imported.model.calibrated
    for column in ("theta", "a", "d", "alpha"):
        assert np.array_equal(getattr(imported.model.dh, column), getattr(model.dh, column)), column
    assert_same_program(imported.steps, as_exported(plan))


def _rows(dh):
    return [dh.a, dh.d, dh.alpha, dh.theta]
