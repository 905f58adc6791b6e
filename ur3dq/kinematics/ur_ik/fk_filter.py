"""Pose input checks and the thesis' FK filter (eq. 4.45): a branch is a solution only if its FK meets the pose."""
from __future__ import annotations

import math

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion
from ur3dq.kinematics.ur_fk import flange_rotation_position, joint_floats
from ur3dq.kinematics.ur_ik.geometry import (
    _flange_of,
    DUPLICATE_TOLERANCE,
    FK_TOLERANCE_M,
    _CHORD_LIMIT,
    _TWO_PI,
    _Geometry,
    _geometry,
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
    differences: no cancellation-prone dot product near 1, no trigonometry per pose (_fk_check: the same for floats)."""
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
    8 coefficients (_fk_check's test, without preparing a function: ik checks one configuration)."""
    g = _geometry(model)
    if g.calibrated:
        return _fk_check(model, g, tcp_coefficients)(q)
    return _flange_meets(flange_rotation_position(*g.half_lengths, *q), g.tcp_offset, _fk_target(tcp_coefficients))


def _fk_check(model, g: _Geometry, tcp_coefficients):
    """The FK filter for one TCP pose (8 coefficients) as a function of 6 joint floats -> bool, the pose's own terms
    prepared once (ik_all checks up to eight branches of one pose).

    The tests of _within_fk_tolerance, written out in floats: the rotation chord against the nearer sign of the
    pose (σ ≡ −σ), then the position. A nominal arm compares its closed-form flange rotation and half position
    (ur_fk.flange_rotation_position, the TCP composed as batch_kernels._tool_rows does: _flange_meets), as the
    batch filter does; a calibrated one the TCP coefficients of its DH chain.
    """
    if g.calibrated:
        tw, tx, ty, tz = tcp_coefficients[:4]
        px, py, pz = _translation_columns(tcp_coefficients)

        def meets(q) -> bool:
            fk = model._fk_floats(q)
            return (_chord2(fk, tw, tx, ty, tz) <= _CHORD_LIMIT2
                    and _distance2(_translation_columns(fk), px, py, pz) <= FK_TOLERANCE_M ** 2)
        return meets
    half_lengths, tool, target = g.half_lengths, g.tcp_offset, _fk_target(tcp_coefficients)
    return lambda q: _flange_meets(flange_rotation_position(*half_lengths, *q), tool, target)


#: Squared limits of the FK filter's tests: the rotation chord, and the half position's distance (metres²).
_CHORD_LIMIT2 = _CHORD_LIMIT ** 2
_HALF_POSITION_LIMIT2 = (0.5 * FK_TOLERANCE_M) ** 2


def _fk_target(tcp_coefficients) -> tuple:
    """(tw, tx, ty, tz, ½px, ½py, ½pz): rotation and half position of a TCP pose's 8 coefficients, as _flange_meets
    compares them."""
    px, py, pz = _translation_columns(tcp_coefficients)
    return (*tcp_coefficients[:4], 0.5 * px, 0.5 * py, 0.5 * pz)


def _flange_meets(flange: tuple, tool, target: tuple) -> bool:
    """Whether flange floats (r, ½p) (7), composed with ``tool`` (g.tcp_offset, None for none), meet ``target``
    (_fk_target) within the FK filter's tolerances: the chord against the nearer sign of the pose, the position."""
    if tool is not None:
        flange = _tool_floats(flange, tool)
    rw, rx, ry, rz, fx, fy, fz = flange
    tw, tx, ty, tz, hx, hy, hz = target
    if rw * tw + rx * tx + ry * ty + rz * tz < 0.0:   # σ ≡ −σ
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    return ((rw - tw) ** 2 + (rx - tx) ** 2 + (ry - ty) ** 2 + (rz - tz) ** 2 <= _CHORD_LIMIT2
            and (fx - hx) ** 2 + (fy - hy) ** 2 + (fz - hz) ** 2 <= _HALF_POSITION_LIMIT2)


def _chord2(r, tw, tx, ty, tz) -> float:
    """|r ∓ t|² of rotation r (its first 4 floats) and t = (tw, tx, ty, tz), the sign nearer r (σ ≡ −σ)."""
    rw, rx, ry, rz = r[:4]
    if rw * tw + rx * tx + ry * ty + rz * tz < 0.0:
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    return (rw - tw) ** 2 + (rx - tx) ** 2 + (ry - ty) ** 2 + (rz - tz) ** 2


def _distance2(p, x, y, z) -> float:
    """|p − (x, y, z)|² of a point p (3 floats)."""
    return (p[0] - x) ** 2 + (p[1] - y) ** 2 + (p[2] - z) ** 2


def _tool_floats(flange: tuple, tool: tuple) -> tuple:
    """(r·r_t, ½(p + r·t_t·r*)) of flange floats (r, ½p) (7) and a tool (r_t (4 floats), ½t_t (3)): the float copy
    of batch_kernels._tool_rows (same expressions)."""
    w, x, y, z, px, py, pz = flange
    (tw, tx, ty, tz), (hx, hy, hz) = tool
    # v + 2w(u×v) + 2u×(u×v), u the vector part of r, v = ½t_t.
    cx, cy, cz = y * hz - z * hy, z * hx - x * hz, x * hy - y * hx
    return (w * tw - x * tx - y * ty - z * tz, w * tx + x * tw + y * tz - z * ty,
            w * ty - x * tz + y * tw + z * tx, w * tz + x * ty - y * tx + z * tw,
            px + (hx + 2.0 * (w * cx + y * cz - z * cy)), py + (hy + 2.0 * (w * cy + z * cx - x * cz)),
            pz + (hz + 2.0 * (w * cz + x * cy - y * cx)))


def _is_new(solution, kept) -> bool:
    """True unless some kept solution agrees with ``solution`` within DUPLICATE_TOLERANCE in every joint (mod 2π).

    A NaN joint difference does not tell two solutions apart (``not … >= tolerance``). θ2 is compared first: it
    differs between every two branches of a regular pose (the θ1 pair and the θ5 pair share some joints)."""
    remainder, tolerance = math.remainder, DUPLICATE_TOLERANCE
    q1, q2, q3, q4, q5, q6 = solution
    for o1, o2, o3, o4, o5, o6 in kept:
        if (not abs(remainder(q2 - o2, _TWO_PI)) >= tolerance and not abs(remainder(q3 - o3, _TWO_PI)) >= tolerance
                and not abs(remainder(q1 - o1, _TWO_PI)) >= tolerance
                and not abs(remainder(q5 - o5, _TWO_PI)) >= tolerance
                and not abs(remainder(q4 - o4, _TWO_PI)) >= tolerance
                and not abs(remainder(q6 - o6, _TWO_PI)) >= tolerance):
            return False
    return True


def _reference(q_ref, name: str = "q_ref") -> tuple:
    """Six finite floats of a joint reference (or weights); ValueError naming ``name`` otherwise."""
    return joint_floats(q_ref, name)
