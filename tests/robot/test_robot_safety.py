"""Pre-send checks: finite six-vectors, limits, travel bound, per-joint speed clamping."""
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ur3dq.errors import SafetyCheckError
from ur3dq.robot import safety

LOWER, UPPER = [-2 * math.pi] * 6, [2 * math.pi] * 6


def test_joint_vector_accepts_six_finite_values():
    assert safety.check_joint_vector([0, 1, 2, 3, 4, 5]).tolist() == [0, 1, 2, 3, 4, 5]


@pytest.mark.parametrize("bad, fragment", [([0] * 5, "shape"), ([0, 0, math.nan, 0, 0, 0], "joint 3"),
                                           ([0, 0, 0, 0, 0, math.inf], "joint 6"), ("abc", "six joint"),
                                           (["0.1"] * 6, "six joint"), ([0.0] * 5 + [True], "six joint")])
def test_joint_vector_rejects(bad, fragment):
    with pytest.raises(SafetyCheckError, match=fragment):
        safety.check_joint_vector(bad)


def test_safety_errors_are_value_errors():
    with pytest.raises(ValueError):
        safety.check_joint_vector([0] * 5)


def test_joint_limits():
    safety.check_joint_limits([2 * math.pi, 0, 0, 0, 0, -2 * math.pi], LOWER, UPPER)
    with pytest.raises(SafetyCheckError, match="joint 2 .* outside"):
        safety.check_joint_limits([0, 6.3, 0, 0, 0, 0], LOWER, UPPER, name="target")


def test_travel_bound():
    safety.check_travel([0] * 6, [0, 0, 0, 0, 0, 3.0], math.pi)
    with pytest.raises(SafetyCheckError, match="joint 6 would travel 6.2832"):
        safety.check_travel([0] * 6, [0, 0, 0, 0, 0, 2 * math.pi], math.pi)


def test_clamp_lowers_to_the_leading_joint_limit():
    a, v = safety.clamp_movej_speed([1.0, 0, 0, 0, 0, 0], 10.0, 10.0, [5.0] * 6, [3.0] * 6)
    assert (a, v) == (5.0, 3.0)


def test_clamp_protects_a_slower_following_joint():
    # joint 1 leads with 2 rad, joint 2 follows with 1 rad: it moves at v/2, so v may be twice its limit.
    a, v = safety.clamp_movej_speed([2.0, 1.0, 0, 0, 0, 0], 10.0, 10.0, [100, 2.0, 100, 100, 100, 100],
                                    [100, 1.0, 100, 100, 100, 100])
    assert (a, v) == (4.0, 2.0)


def test_clamp_keeps_values_already_within_limits():
    assert safety.clamp_movej_speed([0.5] * 6, 1.4, 1.05, [40.0] * 6, [3.14] * 6) == (1.4, 1.05)


@given(st.lists(st.floats(-6, 6), min_size=6, max_size=6), st.floats(0.01, 50), st.floats(0.01, 50))
def test_clamped_motion_never_exceeds_any_joint_limit(delta, a, v):
    max_acc, max_speed = np.array([5, 5, 5, 10, 10, 10.0]), np.array([3.14, 3.14, 3.14, 6.28, 6.28, 6.28])
    a2, v2 = safety.clamp_movej_speed(delta, a, v, max_acc, max_speed)
    assert a2 <= a and v2 <= v
    leading = max(abs(x) for x in delta)
    if leading > 0:
        share = np.abs(delta) / leading
        assert np.all(share * v2 <= max_speed * (1 + 1e-12))
        assert np.all(share * a2 <= max_acc * (1 + 1e-12))


@pytest.mark.parametrize("a, v", [(0, 1), (1, -1), (math.nan, 1), ("x", 1), ("1.5", 1), (1, True)])
def test_clamp_rejects_bad_a_v(a, v):
    with pytest.raises(SafetyCheckError):
        safety.clamp_movej_speed([1] * 6, a, v, [1] * 6, [1] * 6)


def test_pose_vector():
    assert safety.check_pose_vector([0, 0, 0.1, 0, 0, 3.1]).tolist() == [0, 0, 0.1, 0, 0, 3.1]
    for bad in ([0, 0, 0.1], [0, 0, math.inf, 0, 0, 0], None):
        with pytest.raises(SafetyCheckError, match="tcp must be a UR pose vector"):
            safety.check_pose_vector(bad, "tcp")
