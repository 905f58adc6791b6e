"""What counts as a number where numbers enter ur3dq: real numbers yes; text and bools no, even where float() and
numpy would read them."""
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ur3dq.real_numbers import is_number, real_array


@pytest.mark.parametrize("value", [0, -3, 1.5, float("nan"), np.float64(2.0), np.float32(0.5), np.int64(7),
                                   Fraction(1, 3), 10 ** 400])
def test_real_numbers_are_numbers(value):
    assert is_number(value)


@pytest.mark.parametrize("value", [True, False, np.bool_(True), "1.5", b"1", None, 1j, [1.0], {}])
def test_text_bools_and_others_are_not(value):
    assert not is_number(value)


@given(st.lists(st.one_of(st.floats(), st.integers(-10 ** 6, 10 ** 6)), max_size=8))
def test_a_list_of_numbers_reads_as_numpy_reads_it(values):
    np.testing.assert_array_equal(real_array(values), np.asarray(values, dtype=float))


@given(st.lists(st.lists(st.floats(allow_nan=False), min_size=3, max_size=3), max_size=4))
def test_rows_of_numbers_read_as_numpy_reads_them(rows):
    np.testing.assert_array_equal(real_array(rows), np.asarray(rows, dtype=float))
    np.testing.assert_array_equal(real_array(tuple(map(tuple, rows))), np.asarray(rows, dtype=float))


def test_a_float_array_is_returned_as_it_is_and_others_converted():
    array = np.arange(6.0)
    assert real_array(array) is array
    assert real_array(np.arange(6)).dtype == np.float64
    assert real_array([Fraction(1, 2), 1]).tolist() == [0.5, 1.0]


@pytest.mark.parametrize("value", [["1.5", 0.0], [0.5, True], [[0.5, 1.0], [False, 2.0]], (0.0, np.bool_(False)),
                                   np.array([True, False]), np.array(["1", "2"]), [None, 1.0], [1j, 1.0],
                                   "1.5", None, [Fraction(1, 2), "x"]])
def test_text_bools_and_others_are_refused_among_numbers(value):
    with pytest.raises(TypeError, match="expected numbers"):
        real_array(value)


def test_ragged_rows_are_numpys_value_error():
    with pytest.raises(ValueError):
        real_array([[1.0, 2.0], [3.0]])
