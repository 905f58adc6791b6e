"""The clearance bounds that let the path check skip dense sampling of joint moves (ur3dq/pathcheck/bounds.py):
the rates really bound how fast each clearance changes, a certified move keeps its margins at every point, and the
check without samples finds what the dense check finds."""
import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, bounds, cell_from_dict, check_path
from ur3dq.pathcheck.checks import StepChecker

CELL = cell_from_dict({
    "floor": {"z": -0.02}, "margin": 0.01,
    "boxes": [{"name": "fixture", "min": [0.15, -0.15, -0.02], "max": [0.35, 0.15, 0.12]},
              {"name": "post", "min": [-0.30, 0.10, -0.02], "max": [-0.20, 0.20, 0.60]}],
    "keep_in": {"min": [-0.9, -0.9, -0.05], "max": [0.9, 0.9, 1.2]},
    "tool": {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.10], "radius": 0.025}}})


def margins_at(checker, joints):
    return np.hstack(checker.clearance_margins(joints))


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur10"])
def test_no_clearance_changes_faster_than_its_rate_in_any_direction(name):
    """Each column's rate (m per rad of each joint) bounds its derivative along random joint directions at random
    configurations: a rate that left out a joint that moves the pair, or a lever too short, fails here."""
    model = robot_model(name)
    checker = StepChecker(model, CELL, Margins())
    rates = bounds.column_rates(checker, bounds.lever_arms(model, checker.capsules))
    rng = np.random.default_rng(11)
    q = rng.uniform(-np.pi, np.pi, (400, 6))
    for _ in range(4):
        direction = rng.normal(size=(400, 6)) * rng.uniform(0, 1, (400, 6)) ** 3   # some joints barely move
        step = 1e-6
        change = (margins_at(checker, q + step * direction) - margins_at(checker, q - step * direction)) / (2 * step)
        allowed = np.abs(direction) @ rates.T
        assert np.all(np.abs(change) <= allowed * (1 + 1e-6) + 1e-7), np.max(np.abs(change) - allowed)


def test_dropping_a_joint_from_the_rates_is_caught():
    """The test above can fail: without joint 4's share, the forearm/wrist-3 pair changes faster than allowed."""
    model = robot_model("ur5e")
    checker = StepChecker(model, None, Margins())
    rates = bounds.column_rates(checker, bounds.lever_arms(model, checker.capsules))
    rates[:, 3] = 0.0
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (200, 6))
    direction = np.zeros((200, 6))
    direction[:, 3] = 1.0
    change = (margins_at(checker, q + 1e-6 * direction) - margins_at(checker, q - 1e-6 * direction)) / 2e-6
    assert np.any(np.abs(change) > np.abs(direction) @ rates.T + 1e-3)


def random_moves(model, count, seed, spread):
    rng = np.random.default_rng(seed)
    start = np.array([0.0, -1.6, 1.4, -1.4, -1.57, 0.0])
    q = start + rng.uniform(-1, 1, (count + 1, 6)) * spread
    return q[:-1], q[1:]


@pytest.mark.parametrize("name, spread", [("ur3", 0.6), ("ur5e", 1.2), ("ur10", 0.7)])
def test_a_certified_move_keeps_its_margins_at_every_point(name, spread):
    """Sampled 2000 times, no certified move comes below its lower bound or below 0; every move that dips below 0
    somewhere is left uncertified (for the dense check to report)."""
    model = robot_model(name)
    checker = StepChecker(model, CELL, Margins(self_collision=0.005))
    q0, q1 = random_moves(model, 60, 3, spread)
    result = bounds.certify_joint_moves(checker, q0, q1)
    fraction = np.linspace(0, 1, 2001)[:, None]
    dipped = 0
    for k in range(len(q0)):
        values = margins_at(checker, q0[k] + fraction * (q1[k] - q0[k]))
        room = checker.limit_room(q0[k] + fraction * (q1[k] - q0[k]))[0]
        smallest = {"self_collision": values[:, :len(checker.pair_a)].min(),
                    "cell": values[:, len(checker.pair_a):].min(), "joint_limit": room.min()}
        if min(smallest.values()) < 0:
            dipped += 1
            assert not result.certified[k]
        if result.certified[k]:
            for check, value in smallest.items():
                assert value >= result.lower[check][k] - 1e-12 and value >= 0, (k, check)
    assert 0 < dipped < len(q0) and result.certified.any()   # the cases exist on both sides


def plan_of(q0, q1, blend_every=0):
    segments = [PathSegment(f"m{k}", "joint", target_joints=q, blend=0.02 if blend_every and k % blend_every == 0
                            else 0.0) for k, q in enumerate(q1)]
    return PathPlan(q0[0], segments)


@pytest.mark.parametrize("name, spread, blend_every", [("ur3", 0.4, 0), ("ur5e", 0.9, 0), ("ur10", 0.5, 5)])
def test_the_check_without_samples_finds_the_dense_problems_and_smallest_margins(name, spread, blend_every):
    """keep_samples=False certifies joint moves by bounds: the same problems as the dense check (which keeps
    samples), and no check's smallest margin over the plan more than tcp_resolution above the dense one's."""
    model = robot_model(name)
    q0, q1 = random_moves(model, 80, 7, spread)
    plan = plan_of(q0, q1, blend_every)
    margins = Margins(self_collision=0.005)
    dense = check_path(model, plan, CELL, margins)
    lean = check_path(model, plan, CELL, margins, keep_samples=False)
    assert lean.problems == dense.problems and lean.problems
    assert [s.name for s in lean.steps] == [s.name for s in dense.steps]
    assert sum(s.samples for s in lean.steps) < sum(s.samples for s in dense.steps)
    for check in ("self_collision", "cell", "joint_limit"):
        smallest_lean = min(s.margins[check] for s in lean.steps)
        smallest_dense = min(s.margins[check] for s in dense.steps)
        assert smallest_dense >= smallest_lean - margins.tcp_resolution - 1e-12, check
    for lean_step, dense_step in zip(lean.steps, dense.steps):
        if lean_step.samples == dense_step.samples:   # sampled densely in both
            assert lean_step.margins == dense_step.margins
        else:
            assert all(value >= 0 for value in lean_step.margins.values())
