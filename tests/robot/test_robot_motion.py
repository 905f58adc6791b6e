"""Trapezoidal durations and speed-slider-aware timeouts."""
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ur3dq.robot import motion

positive = st.floats(min_value=1e-3, max_value=50, allow_nan=False)


def test_trapezoid_with_cruise():
    # D = 2 rad, a = 1, v = 1: accelerate 0.5 rad in 1 s, cruise 1 rad in 1 s, decelerate 1 s.
    assert motion.trapezoid_duration(2.0, 1.0, 1.0) == pytest.approx(3.0)


def test_trapezoid_triangular():
    # D = 0.25, a = 1: never reaches v = 1; 0.125 rad in 0.5 s each way.
    assert motion.trapezoid_duration(0.25, 1.0, 1.0) == pytest.approx(1.0)


@given(st.lists(st.floats(min_value=0, max_value=20), max_size=20), positive, positive)
def test_trapezoid_durations_are_trapezoid_duration_for_every_distance(distances, a, v):
    """The array form gives the scalar one's seconds to the last bit, on both sides of the cruise threshold."""
    distances += [v * v / a, 0.5 * v * v / a, 2.0 * v * v / a]
    assert motion.trapezoid_durations(distances, a, v).tolist() == \
        [motion.trapezoid_duration(d, a, v) for d in distances]


@given(st.lists(st.tuples(st.floats(min_value=0, max_value=20), positive, positive), max_size=20))
def test_trapezoid_durations_with_each_moves_own_a_and_v(moves):
    """a and v as arrays (a cell program's moves each have their own): each move's scalar seconds, to the bit."""
    moves += [(v * v / a, a, v) for _, a, v in moves[:3]]   # on the cruise threshold
    distances, a, v = (list(column) for column in zip(*moves)) if moves else ([], [], [])
    assert motion.trapezoid_durations(distances, a, v).tolist() == \
        [motion.trapezoid_duration(*move) for move in moves]


def test_leading_travels_are_leading_travel_of_each_move():
    rng = np.random.default_rng(3)
    path = rng.uniform(-6, 6, (9, 6))
    assert motion.leading_travels(path).tolist() == [motion.leading_travel(p, q) for p, q in zip(path, path[1:])]
    assert motion.leading_travels(path[:1]).shape == (0,) and motion.leading_travels([]).shape == (0,)


@pytest.mark.parametrize("distances, a, v, message", [
    ([0.1, -1.0], 1.0, 1.0, "distance must be finite and ≥ 0, got -1.0"),
    ([math.nan], 1.0, 1.0, "distance must be finite and ≥ 0, got nan"),
    ([], 0.0, 1.0, r"a \(acceleration\) must be finite and > 0, got 0.0"),
    ([1.0], 1.0, math.inf, r"v \(speed\) must be finite and > 0, got inf"),
    ([1.0, 2.0], [1.0, -1.0], 1.0, r"a \(acceleration\) must be finite and > 0, got -1.0"),
    ([1.0, 2.0, 3.0], 1.0, [1.0, 2.0, math.nan], r"v \(speed\) must be finite and > 0, got nan"),
    ([1.0, -2.0], [1.0, 0.0], 1.0, "distance must be finite and ≥ 0, got -2.0"),
])
def test_trapezoid_durations_refuse_what_trapezoid_duration_refuses(distances, a, v, message):
    with pytest.raises(ValueError, match=message):
        motion.trapezoid_durations(distances, a, v)


@given(st.floats(min_value=0, max_value=20), positive, positive)
def test_trapezoid_is_continuous_and_no_faster_than_cruise(distance, a, v):
    duration = motion.trapezoid_duration(distance, a, v)
    assert duration >= distance / v - 1e-12
    boundary = v * v / a
    assert motion.trapezoid_duration(boundary, a, v) == pytest.approx(2 * v / a)


def test_trapezoid_zero_distance():
    assert motion.trapezoid_duration(0.0, 1.4, 1.05) == 0.0


@pytest.mark.parametrize("args, name", [((-1, 1, 1), "distance"), ((1, 0, 1), "a"), ((1, 1, math.nan), "v")])
def test_trapezoid_rejects(args, name):
    with pytest.raises(ValueError, match=name):
        motion.trapezoid_duration(*args)


def test_movej_duration_is_led_by_the_longest_travel():
    q0 = [0, 0, 0, 0, 0, 0]
    q1 = [0.1, -2.0, 0.5, 0, 0, 0]
    assert motion.movej_duration(q0, q1, 1.0, 1.0) == pytest.approx(motion.trapezoid_duration(2.0, 1.0, 1.0))


def test_path_duration_sums_segments():
    q0, q1, q2 = [0] * 6, [1] * 6, [0] * 6
    assert motion.path_duration(q0, [q1, q2], 1.4, 1.05) == pytest.approx(2 * motion.movej_duration(q0, q1, 1.4, 1.05))


def test_timeout_grows_as_the_slider_slows():
    assert motion.motion_timeout(2.0, 1.0) == pytest.approx(2.0 * 1.5 + 1.0)
    assert motion.motion_timeout(2.0, 0.5) == pytest.approx(4.0 * 1.5 + 1.0)


def test_timeout_is_finite_with_the_slider_at_zero():
    assert motion.motion_timeout(1.0, 0.0) == pytest.approx(1.0 / motion.MIN_SPEED_FRACTION * 1.5 + 1.0)


def test_timeout_rejects_nan():
    with pytest.raises(ValueError, match="speed_fraction"):
        motion.motion_timeout(1.0, math.nan)
