"""The numpy array types of ur3dq's annotations: the dtype is in the type, the shape in the docstring.

    from ur3dq.array_types import FloatArray

    def tcp_positions(joints: FloatArray) -> FloatArray:   # joints (n, 6) rad -> positions (n, 3) m
"""
from __future__ import annotations

from typing import TypeAlias

import numpy as np
import numpy.typing as npt

#: float64 arrays: joints, poses, positions, margins.
FloatArray: TypeAlias = npt.NDArray[np.float64]
#: Integer arrays: indices (numpy's argmin, flatnonzero) and counts.
IntArray: TypeAlias = npt.NDArray[np.intp]
#: Boolean arrays: masks.
BoolArray: TypeAlias = npt.NDArray[np.bool_]
