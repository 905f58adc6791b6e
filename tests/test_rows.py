"""ur3dq.rows.float_rows: the same array as np.array, by a faster path for tuples of floats."""
import numpy as np
import pytest

from ur3dq.rows import float_rows


def test_tuples_give_np_arrays_array():
    rows = [tuple(row) for row in np.random.default_rng(0).normal(size=(50, 8)).tolist()]
    fast = float_rows(rows, 8)
    assert fast.shape == (50, 8) and fast.dtype == float
    np.testing.assert_array_equal(fast, np.array(rows, dtype=float))


@pytest.mark.parametrize("rows", [[np.arange(6.0), np.ones(6)], [[1, 2, 3, 4, 5, 6]], [(1, 2, 3, 4, 5, 6), [0] * 6],
                                  []])
def test_other_rows_are_np_arrays_own(rows):
    np.testing.assert_array_equal(float_rows(rows, 6), np.array(rows, dtype=float))
    assert float_rows(rows, 6).shape == np.array(rows, dtype=float).shape


def test_a_row_of_another_length_is_refused_as_np_array_refuses_it():
    # chained into fromiter, a long row would shift every number after it, and a short one would end the count
    for rows in ([(1.0,) * 6, (1.0,) * 7, (2.0,) * 5], [(1.0,) * 6, (1.0,) * 5]):
        with pytest.raises(ValueError):
            np.array(rows, dtype=float)
        with pytest.raises(ValueError):
            float_rows(rows, 6)


def test_a_generator_is_read_once():
    np.testing.assert_array_equal(float_rows(((float(i),) * 3 for i in range(4)), 3),
                                  np.repeat(np.arange(4.0), 3).reshape(4, 3))
