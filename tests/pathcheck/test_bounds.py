"""The clearance bounds that let the path check skip dense sampling of joint moves (ur3dq/pathcheck/bounds.py):
the rates really bound how fast each clearance changes, a certified move keeps its margins at every point, and the
check without samples finds what the dense check finds."""
import numpy as np
import pytest

from ur3dq.kinematics import robot_model
from ur3dq.pathcheck import Margins, PathPlan, PathSegment, bounds, cell_from_dict, check_path, checks
from ur3dq.pathcheck.checks import StepChecker

CELL = cell_from_dict({
    "floor": {"z": -0.02}, "margin": 0.01,
    "boxes": [{"name": "fixture", "min": [0.15, -0.15, -0.02], "max": [0.35, 0.15, 0.12]},
              {"name": "post", "min": [-0.30, 0.10, -0.02], "max": [-0.20, 0.20, 0.60]}],
    "keep_in": {"min": [-0.9, -0.9, -0.05], "max": [0.9, 0.9, 1.2]},
    "tool": {"capsule": {"from": [0, 0, 0], "to": [0, 0, 0.10], "radius": 0.025}}})


def margins_at(checker, joints):
    return np.hstack(checker.clearance_margins(joints))


@pytest.fixture
def exact_cell(monkeypatch):
    """Cell clearances computed exactly at every distance (the checker keeps a cheaper lower bound for boxes
    further than EXACT_RANGE, which is not the clearance the bounds bound)."""
    monkeypatch.setattr(checks, "EXACT_RANGE", np.inf)


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


@pytest.mark.parametrize("name", ["ur3", "ur5e", "ur10"])
def test_no_clearance_bends_down_faster_than_its_bound(name, exact_cell):
    """Along a joint move, each column's second difference (over steps h of the move's parameter) stays under the
    curvature bound H + L²/(distance) of bounds.column_slopes: a clearance lies above its chords less that bend."""
    model = robot_model(name)
    checker = StepChecker(model, CELL, Margins(self_collision=0.005))
    rates = bounds.column_rates(checker, bounds.lever_arms(model, checker.capsules))
    offsets = bounds.column_offsets(checker)
    rng = np.random.default_rng(13)
    q = rng.uniform(-np.pi, np.pi, (400, 6))
    worst = -np.inf
    for _ in range(4):
        delta = rng.normal(size=(400, 6)) * rng.uniform(0, 1, (400, 6)) ** 3
        rate, bend = bounds.column_slopes(rates, np.abs(delta))
        h = 1e-3
        m_minus, m, m_plus = (margins_at(checker, q + t * delta) for t in (-h, 0.0, h))
        distance = np.minimum(np.minimum(m_minus, m), m_plus) - rate * h + offsets   # least over [−h, h]
        allowed = np.where(distance > 0, bend + rate ** 2 / distance, np.inf)
        second = (m_plus - 2 * m + m_minus) / h ** 2
        assert np.all(second <= allowed * (1 + 1e-6) + 1e-6), np.max(second - allowed)
        worst = max(worst, np.max(second / np.maximum(allowed, 1e-300)))
    assert worst > 0.05   # the bound is not vacuous: some columns bend by a fair part of it


def test_leaving_out_the_speed_term_of_the_bend_is_caught(exact_cell):
    """The test above can fail: without L²/distance, capsules turning past each other bend more than H allows."""
    model = robot_model("ur5e")
    checker = StepChecker(model, CELL, Margins())
    rates = bounds.column_rates(checker, bounds.lever_arms(model, checker.capsules))
    rng = np.random.default_rng(13)
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    delta = rng.normal(size=(2000, 6))
    bend = bounds.column_slopes(rates, np.abs(delta))[1]
    h = 1e-3
    m_minus, m, m_plus = (margins_at(checker, q + t * delta) for t in (-h, 0.0, h))
    assert np.any((m_plus - 2 * m + m_minus) / h ** 2 > bend + 1e-3)


def test_an_interval_bound_is_the_better_of_the_lipschitz_and_the_chord_bound():
    """interval_bound on hand-made figures: a column that does not move keeps its margin, a bend lowers the
    chord, a near contact leaves the Lipschitz bound, and unevaluated (+inf) columns stay +inf."""
    one = np.ones((1, 1))
    assert bounds.interval_bound(0.1 * one, 0.1 * one, one, 0.0 * one, 0.0 * one, 0.05)[0, 0] == 0.1
    bent = bounds.interval_bound(0.2 * one, 0.2 * one, one, 0.2 * one, 0.1 * one, 0.05)[0, 0]
    speed = 0.2 ** 2 / (0.05 + 0.1)   # L² over the least distance: offset + the Lipschitz bound 0.1
    assert bent == pytest.approx(0.2 - (0.1 + speed) / 8) and bent > 0.1
    assert bounds.interval_bound(0.01 * one, 0.01 * one, one, 1.0 * one, 0.1 * one, 0.05)[0, 0] == \
        pytest.approx(0.5 * (0.02 - 1.0))
    assert bounds.interval_bound(np.inf * one, 0.2 * one, one, one, one, 0.05)[0, 0] == np.inf


@pytest.mark.parametrize("name, spread", [("ur3", 0.6), ("ur5e", 1.2), ("ur10", 0.7)])
def test_a_certified_move_keeps_its_margins_at_every_point(name, spread, monkeypatch):
    """Sampled 2000 times, no certified move comes below its lower bound or below 0 (its exact clearances: the
    bounds bound those, from the checker's cheaper figures); every move that dips below 0 somewhere is left
    uncertified (for the dense check to report)."""
    model = robot_model(name)
    checker = StepChecker(model, CELL, Margins(self_collision=0.005))
    q0, q1 = random_moves(model, 60, 3, spread)
    result = bounds.certify_joint_moves(checker, q0, q1)
    monkeypatch.setattr(checks, "EXACT_RANGE", np.inf)
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
