"""Joint vectors as a person or a file gives them, checked into six floats (kept cheap: this is on the single-FK
path)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ur3dq.real_numbers import is_number

_NUMBER_TYPES = frozenset({float, int, np.float64})
#: No joint angle is this large (even an unlimited wrist 3 would need 160,000 turns); beyond it sums of angles
#: overflow and sines lose every digit, so such a value is refused by name rather than computed with.
MAX_JOINT_ANGLE = 1e6
_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def joint_floats(q: Any, name: str = "q") -> tuple[float, ...]:
    """Six finite floats from ``q``; ValueError naming ``name`` (kept cheap: this is on the single-FK path)."""
    try:
        if isinstance(q, np.ndarray) and q.dtype == np.float64 and q.ndim == 1:
            values = tuple(q.tolist())   # Python floats in one call (iterating yields slow numpy scalars)
        else:
            items = tuple(q)
            if not _NUMBER_TYPES.issuperset(map(type, items)) and not all(map(is_number, items)):
                raise TypeError("not numbers")   # float() would read "1.5" and True
            values = tuple(map(float, items))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected 6 joint angles (radians), got {q!r}") from exc
    if len(values) != 6:
        raise ValueError(f"{name}: expected 6 joint angles, got {len(values)}")
    if not sum(map(abs, values)) < MAX_JOINT_ANGLE:   # False for NaN and inf too: then look closer
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"{name}: contains NaN or infinite values")
        for joint, value in enumerate(values):
            if abs(value) >= MAX_JOINT_ANGLE:
                raise ValueError(f"{name}: joint {joint + 1} = {value:.6g} rad is not a joint angle "
                                 f"(|q| must be below {MAX_JOINT_ANGLE:g} rad)")
    return values
