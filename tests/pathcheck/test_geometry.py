"""The distance kernels against brute force, the capsule model's sanity, the cell file's parsing."""
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ur3dq.errors import StoreError
from ur3dq.kinematics import MODEL_NAMES, robot_model
from ur3dq.pathcheck import ToolShape, cell_from_dict, geometry, load_cell

coordinate = st.floats(-1.0, 1.0, allow_nan=False)
point = st.tuples(coordinate, coordinate, coordinate).map(np.array)


def dense(p0, p1, count=4001):
    return p0 + np.linspace(0.0, 1.0, count)[:, None] * (p1 - p0)


@settings(max_examples=200, deadline=None)
@given(point, point, point, point)
def test_segment_segment_distance_matches_brute_force(p0, p1, q0, q1):
    brute = np.min(np.linalg.norm(dense(p0, p1, 601)[:, None] - dense(q0, q1, 601)[None], axis=2))
    exact = float(geometry.segment_segment_distance(p0, p1, q0, q1))
    spacing = max(np.linalg.norm(p1 - p0), np.linalg.norm(q1 - q0)) / 600
    assert exact <= brute + 1e-9 and brute <= exact + spacing + 1e-9


@settings(max_examples=200, deadline=None)
@given(point, point, point, st.tuples(*[st.floats(0.01, 0.5)] * 3).map(np.array))
def test_segment_box_distance_matches_brute_force(p0, p1, lo, size):
    hi = lo + size
    samples = dense(p0, p1)
    outside = np.linalg.norm(np.maximum(np.maximum(lo - samples, samples - hi), 0.0), axis=1)
    depth = np.min(np.minimum(samples - lo, hi - samples), axis=1)
    exact = float(geometry.segment_box_distance(p0, p1, lo, hi))
    bound = float(geometry.segment_box_bound(p0, p1, lo, hi))
    spacing = np.linalg.norm(p1 - p0) / 4000 + 1e-12
    if outside.min() > spacing:                  # clearly outside: the exact distance, and the bound below it
        assert exact == pytest.approx(outside.min(), abs=spacing + 1e-9)
        assert bound <= exact + 1e-12
    if depth.max() > spacing:                    # clearly inside: reported inside, never deeper than it is
        assert exact < 0 and -exact <= depth.max() + spacing


def test_a_segment_through_a_box_reports_its_depth():
    lo, hi = np.zeros(3), np.ones(3)
    assert geometry.segment_box_distance(np.array([-1.0, 0.5, 0.5]), np.array([2.0, 0.5, 0.5]), lo, hi) == -0.5
    assert geometry.segment_box_distance(np.array([-1.0, 0.5, 0.9]), np.array([2.0, 0.5, 0.9]), lo, hi) \
        == pytest.approx(-0.1)
    assert geometry.segment_box_distance(np.array([-1.0, 2.0, 1.5]), np.array([2.0, 2.0, 1.5]), lo, hi) \
        == pytest.approx(np.hypot(1.0, 0.5))


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_every_model_is_clear_of_itself_at_home_and_stretched(name):
    from ur3dq.pathcheck.checks import Margins, StepChecker
    from ur3dq.pathcheck.path_plan import PathSegment

    model = robot_model(name)
    checker = StepChecker(model, None, Margins())
    joints = np.array([[0, -np.pi / 2, 0, -np.pi / 2, 0, 0], [0, 0, 0, 0, 0, 0], [0, -1.57, 1.57, -1.57, -1.57, 0]])
    margins = checker.margins_of(PathSegment("x", target_joints=np.zeros(6)), joints, np.linspace(0, 1, 3),
                                 None, np.zeros(3), 0.0)
    assert np.all(margins["self_collision"][0] > 0)


def test_a_box_tool_becomes_a_capsule_containing_its_corners():
    tool = ToolShape.box([-0.02, -0.03, 0.0], [0.02, 0.03, 0.15])
    corners = np.array([[x, y, z] for x in (-0.02, 0.02) for y in (-0.03, 0.03) for z in (0.0, 0.15)])
    distance = geometry.segment_segment_distance(tool.a, tool.b, corners, corners)
    assert np.all(distance <= tool.radius + 1e-12)


def test_the_issue_s_cell_example_loads(tmp_path):
    path = tmp_path / "cell.json"
    path.write_text(json.dumps({"floor": {"z": 0.0}, "boxes": [{"name": "fixture", "min": [0.2, -0.1, 0.0],
                                                                "max": [0.4, 0.1, 0.3]}],
                                "keep_in": {"min": [-1, -1, 0], "max": [1, 1, 1.5]}, "margin": 0.01}))
    cell = load_cell(path)
    assert cell.floor_z == 0.0 and cell.boxes[0].name == "fixture" and cell.margin == 0.01
    assert np.array_equal(cell.keep_in.hi, [1, 1, 1.5]) and cell.tool is None


@pytest.mark.parametrize("data, fragment", [
    ([], "JSON object"), ({"floor": {"height": 0}}, '"floor"'), ({"boxes": {}}, '"boxes" must be a list'),
    ({"boxes": [{"min": [0, 0], "max": [1, 1, 1]}]}, "3 numbers"), ({"margin": -0.1}, "≥ 0"),
    ({"tool": {"cone": {}}}, '"tool"'), ({"floor": {"z": float("nan")}}, "finite"),
    ({"floor": {"z": 1e300}}, "floor z must be within ±100 m of the base, got 1e+300 m"),   # not 300 digits later
    ({"boxes": [{"min": [0, 0, 0], "max": [1, 1, 150]}]}, "max must be within ±100 m"),   # mm typed as m
])
def test_bad_cells_are_one_clear_error(data, fragment):
    with pytest.raises(ValueError, match="cell") as error:
        cell_from_dict(data)
    assert fragment in str(error.value)


def test_an_unreadable_cell_file_is_a_store_error(tmp_path):
    with pytest.raises(StoreError, match="no such file. Write it"):
        load_cell(tmp_path / "missing.json")
    (tmp_path / "folder.json").mkdir()
    with pytest.raises(StoreError, match="cannot read"):
        load_cell(tmp_path / "folder.json")
