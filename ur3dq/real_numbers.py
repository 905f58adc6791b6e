"""What counts as a real number where numbers enter ur3dq (the Python API, files, the command line).

float() and np.asarray(dtype=float) read the text "1.5" as 1.5 and the bool True as 1.0 (a bool is an int in
Python), so a CSV column left as text or a flag passed by mistake would become a joint angle. These refuse both.
"""
from __future__ import annotations

import itertools
import numbers
from collections.abc import Iterator
from typing import Any

import numpy as np

_BOOLS = frozenset({bool, np.bool_})


def is_number(value: object) -> bool:
    """Whether `value` is a real number (not a bool, not text).

    Whether ``value`` is a real number: an int, a float or a numpy integer or floating scalar (any
    numbers.Real); not a bool or numpy bool, nor text that float() would read."""
    kind = type(value)
    if kind is float or kind is int:   # the common case, without the ABC's slower isinstance
        return True
    return isinstance(value, numbers.Real) and kind not in _BOOLS


def real_array(value: object) -> np.ndarray:
    """`value` as a float array, refusing text, bools and None.

    ``value`` as a float array, as np.asarray(value, dtype=float) gives it (its shapes, its ValueError for
    ragged rows), but TypeError for text, bools, None or other objects among the numbers.

    A numpy array is judged by its dtype (integer or floating). A list or tuple, nested or not, also by its items'
    types: numpy reads [True, 0.5] as [1.0, 0.5]."""
    array = np.asarray(value)
    kind = array.dtype.kind
    if kind == "O":   # objects: numbers of other types (Fraction, Decimal) or anything else
        bad = [item for item in array.ravel().tolist() if not is_number(item)]
        if bad:
            raise TypeError(f"expected numbers, got {bad[0]!r}")
        return array.astype(float)
    if kind not in "fiu":   # text, bools, complex numbers, dates
        raise TypeError(f"expected numbers, got {array.dtype} values")
    if isinstance(value, (list, tuple)) and not _BOOLS.isdisjoint(map(type, _leaves(value, array.ndim))):
        raise TypeError("expected numbers, got a bool among them")
    return array.astype(float, copy=False)


def _leaves(rows: Any, depth: int) -> Iterator[Any]:
    """The items of ``rows`` nested ``depth`` deep (regular: np.asarray has read them as that many dimensions)."""
    for _ in range(depth - 1):
        rows = itertools.chain.from_iterable(rows)
    return iter(rows)
