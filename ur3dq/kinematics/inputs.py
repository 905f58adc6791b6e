"""The kinematics' inputs as a person, a file or a caller gives them, checked into floats: joint vectors, poses
(DualQuaternion or 8 coefficients, one or (N, 8)) and joint weights. Each check raises ValueError naming the input
and what is wrong; the single-pose checks stay in Python floats, as they are on the single FK/IK path.

>>> joint_floats([0, -1.57, 1.57, 0, 1.57, 0])
(0.0, -1.57, 1.57, 0.0, 1.57, 0.0)
>>> joint_weights(None).tolist()
[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.real_numbers import is_number, real_array

_NUMBER_TYPES = frozenset({float, int, np.float64})
#: No joint angle is this large (even an unlimited wrist 3 would need 160,000 turns); beyond it sums of angles
#: overflow and sines lose every digit, so such a value is refused by name rather than computed with.
MAX_JOINT_ANGLE = 1e6
#: A pose whose |r|² − 1 or r·d exceeds this (but passes the unit check) is normalised before solving: a pose
#: read with 8 significant digits is a pose, and solved unnormalised every branch would miss the FK filter.
EXACT_UNIT = 1e-13
UNIT_WEIGHTS = np.ones(6)


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


def pose_row(pose: Any) -> np.ndarray:
    """(1, 8) unit pose coefficients of a DualQuaternion or 8 numbers, normalised where off unit by more than
    rounding (within dqarray.UNIT_TOLERANCE); ValueError naming ``pose`` for anything that is not a rigid transform.
    Checked in Python floats: numpy's calls on 8 numbers would cost more than the IK."""
    if isinstance(pose, DualQuaternion):
        values = pose.to_array()
    else:
        try:
            values = real_array(pose)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"pose: expected a DualQuaternion or 8 coefficients, got {pose!r}") from exc
        if values.shape != (8,):
            raise ValueError(f"pose: expected a DualQuaternion or 8 coefficients, got shape {values.shape}")
    rw, rx, ry, rz, dw, dx, dy, dz = values.tolist()
    norm2, orthogonality = rw * rw + rx * rx + ry * ry + rz * rz, rw * dw + rx * dx + ry * dy + rz * dz
    if not math.isfinite(norm2 + orthogonality + dw + dx + dy + dz):
        raise ValueError("pose: contains NaN or infinite values")
    if abs(norm2 - 1.0) > 2.0 * dqarray.UNIT_TOLERANCE:
        raise ValueError(f"pose: rotation part is not a unit quaternion (norm² {norm2:.6g})")
    if abs(orthogonality) > dqarray.UNIT_TOLERANCE:
        raise ValueError(f"pose: not a unit dual quaternion (real·dual = {orthogonality:.3g}, must be 0)")
    if abs(norm2 - 1.0) > EXACT_UNIT or abs(orthogonality) > EXACT_UNIT:
        return dqarray.normalise(values[None])
    return values.reshape(1, 8)


def unit_pose_rows(poses: Any) -> np.ndarray:
    """``poses`` as rows (N, 8) checked finite and unit (dqarray.UNIT_TOLERANCE), those off by more than EXACT_UNIT
    normalised; ValueError naming ``poses`` otherwise."""
    try:
        rows = real_array(poses)
    except (TypeError, ValueError) as exc:
        raise ValueError("poses: expected numbers, 8 coefficients per pose") from exc
    if rows.ndim != 2 or rows.shape[1] != 8:
        raise ValueError(f"poses: expected shape (N, 8), got {rows.shape}")
    rows = dqarray.check_unit(rows, "poses")
    if not np.all(np.isfinite(rows)):
        raise ValueError("poses: contains NaN or infinite values")
    norm2 = np.einsum("ij,ij->i", rows[:, :4], rows[:, :4])
    if np.any(np.abs(norm2 - 1.0) > 2.0 * dqarray.UNIT_TOLERANCE):
        worst = float(norm2[np.argmax(np.abs(norm2 - 1.0))])
        raise ValueError(f"poses: rotation part is not a unit quaternion (norm² {worst:.6g})")
    orthogonality = np.einsum("ij,ij->i", rows[:, :4], rows[:, 4:])
    if np.any(np.abs(orthogonality) > dqarray.UNIT_TOLERANCE):
        worst = float(orthogonality[np.argmax(np.abs(orthogonality))])
        raise ValueError(f"poses: not a unit dual quaternion (real·dual = {worst:.3g}, must be 0)")
    off = (np.abs(norm2 - 1.0) > EXACT_UNIT) | (np.abs(orthogonality) > EXACT_UNIT)
    if off.any():
        rows = rows.copy()
        rows[off] = dqarray.normalise(rows[off])
    return np.ascontiguousarray(rows, dtype=float)


def joint_rows(values: Any, count: int, name: str) -> np.ndarray:
    """(count, 6) finite joint values from (6,) or (count, 6) numbers; ValueError naming ``name``."""
    try:
        array = real_array(values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected 6 joint angles (radians), or a row of 6 per pose, as numbers") from exc
    if array.shape == (6,):
        array = np.broadcast_to(array, (count, 6))
    if array.shape != (count, 6):
        raise ValueError(f"{name}: expected shape (6,) or ({count}, 6), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return np.ascontiguousarray(array, dtype=float)


def joint_weights(weights: Any) -> np.ndarray:
    """Six positive finite joint weights (default all 1); ValueError naming ``weights`` otherwise."""
    if weights is None:
        return UNIT_WEIGHTS
    values = np.array(joint_floats(weights, "weights"))
    if np.any(values <= 0.0):
        raise ValueError(f"weights: every joint weight must be > 0, got {values.tolist()}")
    return values
