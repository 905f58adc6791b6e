"""A StepReport's margins and worst samples (ur3dq/pathcheck/reports.py, Figures): read-only mappings that
compare, read and print as the dicts they stand for, and a big plan's certified reports share equal worst ones."""
import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import PathPlan, PathSegment, cell_from_dict, check_path
from ur3dq.pathcheck.reports import Figures


def test_figures_read_like_a_dict():
    figures = Figures(("self_collision", "joint_limit"), (0.05, 1.5))
    assert figures == {"self_collision": 0.05, "joint_limit": 1.5} and {"joint_limit": 1.5} != figures
    assert figures["joint_limit"] == 1.5 and figures.get("cell") is None and "cell" not in figures
    assert list(figures.items()) == [("self_collision", 0.05), ("joint_limit", 1.5)] and len(figures) == 2
    assert repr(figures) == "{'self_collision': 0.05, 'joint_limit': 1.5}"
    with pytest.raises(KeyError, match="cell"):
        figures["cell"]
    with pytest.raises((AttributeError, TypeError)):
        figures["cell"] = 0.1


def test_certified_reports_give_margins_and_share_equal_worst_samples():
    rng = np.random.default_rng(2)
    q = np.array([0.0, -1.6, 1.4, -1.4, -1.57, 0.0]) + rng.uniform(-0.05, 0.05, (30, 6))
    plan = PathPlan(q[0], [PathSegment(f"m{i}", target_joints=target) for i, target in enumerate(q[1:])])
    result = check_path(robot_model("ur5e"), plan, keep_samples=False)
    assert result.ok and len(result.steps) == 29
    assert all(set(step.margins) == {"self_collision", "joint_limit"} for step in result.steps)
    assert all(step.to_dict()["margins"]["joint_limit"] > 0 for step in result.steps)
    worst = {}
    for step in result.steps:
        worst.setdefault(tuple(step.worst.values()), set()).add(id(step.worst))
    assert all(len(ids) == 1 for ids in worst.values()) and len(worst) < len(result.steps)


def test_lazy_reports_read_as_the_reports_they_stand_for():
    """StepReports' own answers (smallest margins, positions named, samples) against the reports read one by one,
    on a plan that mixes certified joint moves, sampled linear and blended moves, and a box some moves cross."""
    rng = np.random.default_rng(5)
    model = robot_model("ur5e")
    q = np.array([0.0, -1.6, 1.4, -1.4, -1.57, 0.0]) + rng.uniform(-0.4, 0.4, (40, 6))
    q[35, 5] = 2 * np.pi - 0.05   # the smallest joint-limit margin: the certified moves into and out of it (a tie)
    segments = []
    for i, target in enumerate(q[1:]):
        if i % 7 == 3:
            segments.append(PathSegment(f"line{i}", "linear", target_pose=model.fk(target).to_array(), speed=0.2))
        else:   # two TCPs: the bounds certify a group of moves per TCP
            segments.append(PathSegment("m19" if i == 0 else f"m{i}", target_joints=target,   # a name used twice
                                        blend=0.01 if i % 11 == 5 else 0.0,
                                        tcp_offset=(0, 0, 0.05, 0, 0, 0) if i % 5 == 1 else None))
    tcp = model.fk(q[20]).translation   # a box around one target: the moves into and out of it fail
    cell = cell_from_dict({"boxes": [{"name": "fixture", "min": list(tcp - 0.02), "max": list(tcp + 0.02)}]})
    result = check_path(model, PathPlan(q[0], segments), cell, keep_samples=False)
    reports = list(result.steps)
    assert len(reports) == len(result.steps) and result.problems
    assert [report.name for report in reports] == [result.steps[i].name for i in range(len(reports))]
    assert [report.name for report in result.steps[2:9:3]] == [reports[i].name for i in (2, 5, 8)]
    assert reports[34].samples < 50 and result.steps.smallest_margins()["joint_limit"][1] == 34   # sampled: ≥ 90
    smallest = {}
    for position, report in enumerate(reports):
        for check, value in report.margins.items():
            if check not in smallest or value < smallest[check][0]:
                smallest[check] = (value, position)
    assert result.steps.smallest_margins() == smallest
    failed = {problem.step for problem in result.problems}
    assert result.steps.positions_named(failed) == [i for i, report in enumerate(reports) if report.name in failed]
    assert result.steps.samples() == sum(report.samples for report in reports)
    assert result.steps[-1].name == reports[-1].name and result.steps[-1].margins == reports[-1].margins
