"""Pose input checks and the thesis' FK filter (eq. 4.45): a branch is a solution only if its FK meets the pose."""
from __future__ import annotations

import math

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics.ur_fk import joint_floats
from ur3dq.kinematics.ur_ik.geometry import (
    _flange_of,
    DUPLICATE_TOLERANCE,
    FK_TOLERANCE_M,
    _CHORD_LIMIT,
    _TWO_PI,
    _Geometry,
    _translation_columns,
)


def _pair_of(c) -> tuple:
    """(qw, qx, qy, qz, px, py, pz) — the thesis pair (q, p) — of a unit dual quaternion's 8 floats: p = 2·d·r*."""
    return tuple(c[:4]) + _translation_columns(c)


#: A pose whose |r|² − 1 or r·d exceeds this (but passes the unit check) is normalised before solving.
_EXACT_UNIT = 1e-13


def _pose_coefficients(pose, name: str) -> tuple:
    """8 floats of a unit pose given as a DualQuaternion or 8 numbers, normalised if it is off unit by more than
    rounding (within dqarray.UNIT_TOLERANCE); ValueError naming ``name`` for anything that is not a rigid transform."""
    if isinstance(pose, DualQuaternion):
        c = pose._c   # its 8 floats as they are: no array round trip on the single-pose path
    else:
        try:
            values = np.asarray(pose, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got {pose!r}") from exc
        if values.shape != (8,):
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got shape {values.shape}")
        c = tuple(values.tolist())
    norm2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3]
    if not math.isfinite(norm2 + c[4] + c[5] + c[6] + c[7]):
        raise ValueError(f"{name}: contains NaN or infinite values")
    if abs(norm2 - 1.0) > 2.0 * dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: rotation part is not a unit quaternion (norm² {norm2:.6g})")
    orthogonality = c[0] * c[4] + c[1] * c[5] + c[2] * c[6] + c[3] * c[7]
    if abs(orthogonality) > dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: not a unit dual quaternion (real·dual = {orthogonality:.3g}, must be 0)")
    if abs(norm2 - 1.0) > _EXACT_UNIT or abs(orthogonality) > _EXACT_UNIT:
        c = _normalised(c, norm2)
    return c


def _normalised(c: tuple, norm2: float) -> tuple:
    """The nearest unit dual quaternion to 8 floats that passed the unit check: r/|r|, the dual part scaled alike and
    made orthogonal to r. A pose read from a file with 8 significant digits is a pose: solving it unnormalised
    would leave every branch ~1e-8 off and fail the FK filter (1e-9)."""
    scale = 1.0 / math.sqrt(norm2)
    real = tuple(v * scale for v in c[:4])
    dual = tuple(v * scale for v in c[4:])
    along = sum(r * d for r, d in zip(real, dual))
    return real + tuple(d - along * r for r, d in zip(real, dual))


def _targets(g: _Geometry, pose) -> tuple:
    """(TCP coefficients (8 floats), flange pair (qw, qx, qy, qz, px, py, pz)) of a TCP pose; flange = pose · tcp⁻¹."""
    c = _pose_coefficients(pose, "pose")
    return c, _pair_of(c if g.tcp_inverse is None else _flange_of(c, g.tcp_inverse))


def _within_fk_tolerance(fk, target) -> np.ndarray:
    """Whether poses fk and target (8 coefficient arrays each) agree: |Δt| ≤ FK_TOLERANCE_M and the rotation
    angle ≤ FK_TOLERANCE_RAD. The chord |r_fk ∓ r| = 2 sin(angle/4) decides the angle exactly, from squared
    differences: no cancellation-prone dot product near 1, no trigonometry per pose (_meets: the same for floats)."""
    fx, fy, fz = _translation_columns(fk)
    tx, ty, tz = _translation_columns(target)
    position_error2 = (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2
    sign = np.where(fk[0] * target[0] + fk[1] * target[1] + fk[2] * target[2] + fk[3] * target[3] < 0.0,
                    -1.0, 1.0)
    chord2 = ((fk[0] - sign * target[0]) ** 2 + (fk[1] - sign * target[1]) ** 2
              + (fk[2] - sign * target[2]) ** 2 + (fk[3] - sign * target[3]) ** 2)
    return (position_error2 <= FK_TOLERANCE_M ** 2) & (chord2 <= _CHORD_LIMIT ** 2)


def _meets(model, q, tcp_coefficients) -> bool:
    """The thesis' FK filter (eq. 4.45) for one pose: the model's FK at the 6 floats ``q`` against the TCP pose's
    8 coefficients, with the tests of _within_fk_tolerance written out in floats (single-pose hot path)."""
    fk = model._fk_floats(q)
    fw, fx, fy, fz = fk[:4]
    tw, tx, ty, tz = tcp_coefficients[:4]
    if fw * tw + fx * tx + fy * ty + fz * tz < 0.0:   # σ ≡ −σ: compare with the nearer sign
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    if (fw - tw) ** 2 + (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2 > _CHORD_LIMIT ** 2:
        return False
    (fx, fy, fz), (tx, ty, tz) = _translation_columns(fk), _translation_columns(tcp_coefficients)
    return (fx - tx) ** 2 + (fy - ty) ** 2 + (fz - tz) ** 2 <= FK_TOLERANCE_M ** 2


def _is_new(solution, kept) -> bool:
    """True unless some kept solution agrees with ``solution`` within DUPLICATE_TOLERANCE in every joint (mod 2π)."""
    for other in kept:
        for x, y in zip(solution, other):
            if abs(math.remainder(x - y, _TWO_PI)) >= DUPLICATE_TOLERANCE:
                break
        else:
            return False
    return True


def _reference(q_ref, name: str = "q_ref") -> tuple:
    """Six finite floats of a joint reference (or weights); ValueError naming ``name`` otherwise."""
    return joint_floats(q_ref, name)
