"""A StepReport's margins and worst samples (ur3dq/pathcheck/path_check.py, Figures): read-only mappings that
compare, read and print as the dicts they stand for, and a big plan's certified reports share equal worst ones."""
import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import PathPlan, PathSegment, check_path
from ur3dq.pathcheck.path_check import Figures


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
