"""Closed-form forward kinematics of a nominal UR arm (joints 2–4 parallel), for one pose and for blocks of poses.

Shared by :mod:`ur3dq.kinematics.models` (``fk``, ``fk_batch``) and :mod:`ur3dq.kinematics.ur_ik` (the batch FK
filter), which is why it is a module of its own: neither of those imports the other's internals. Frames and
conventions: docs/conventions.md (standard DH, flange = DH frame 6; σ = r + ε½tr, coefficients (w, x, y, z)).
"""
from __future__ import annotations

import math

import numpy as np

from ur3dq.dqarray import sincos_of_half
from ur3dq.real_numbers import is_number

#: No joint angle is this large (even an unlimited wrist 3 would need 160,000 turns); beyond it sums of angles
#: overflow and sines lose every digit, so such a value is refused by name rather than computed with.
MAX_JOINT_ANGLE = 1e6

#: Item types of a joint vector accepted at a glance; any other is judged by is_number.
_NUMBER_TYPES = frozenset({float, int, np.float64})


def joint_floats(q, name: str = "q") -> tuple:
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


def flange_coefficients(d1, a2, a3, d4, d5, d6, q1, q2, q3, q4, q5, q6) -> tuple:
    """Flange σ (8 coefficients) of a nominal UR arm, given HALF the DH lengths (d1/2, a2/2, …); q floats.

    Rotation r = [rz(q1)·rx(π/2)]·[rz(q234)·rx(π/2)]·[rz(q5)·rx(−π/2)·rz(q6)]. The first two factors multiply out
    to (−s1 sb, c1 cb, s1 cb, c1 sb) and the third to k(cP, −cM, −sM, sP), k = 1/√2, with half angles
    1 = q1/2, b = q234/2, P = (q5 + q6)/2, M = (q5 − q6)/2; collecting terms, with X = cb cM − sb sP,
    Y = cb sM − sb cP, Z = cb cP + sb sM, W = cb sP + sb cM:
    r = k(c1 X + s1 Y, c1 Z + s1 W, s1 Z − c1 W, s1 X − c1 Y).
    The position is that of the planar arm (joints 2–4) in frame 1 (full angles):
    p = (c1 ρ + s1 δ, s1 ρ − c1 δ, d1 + a2 s2 + a3 s23 − d5 c234 − d6 s5 s234),
    ρ = a2 c2 + a3 c23 + d5 s234 − d6 s5 c234, δ = d4 + d6 c5. Half lengths give ½p directly for the dual ½·p·r.
    """
    rw, rx, ry, rz, px, py, pz = flange_rotation_position(d1, a2, a3, d4, d5, d6, q1, q2, q3, q4, q5, q6)
    # Dual part (0, p/2)·r.
    return (
        rw, rx, ry, rz,
        -px * rx - py * ry - pz * rz,
        px * rw + py * rz - pz * ry,
        -px * rz + py * rw + pz * rx,
        px * ry - py * rx + pz * rw,
    )


def flange_rotation_position(d1, a2, a3, d4, d5, d6, q1, q2, q3, q4, q5, q6) -> tuple:
    """(rw, rx, ry, rz, ½px, ½py, ½pz): the flange rotation and half position of :func:`flange_coefficients` (same
    arguments and closed form: HALF the DH lengths, q floats), without the dual part: what the IK's FK filter
    compares, and what flange_coefficients completes with the dual part."""
    q23 = q2 + q3
    q234 = q23 + q4
    sin, cos = math.sin, math.cos
    half1, half234, half_p, half_m = 0.5 * q1, 0.5 * q234, 0.5 * (q5 + q6), 0.5 * (q5 - q6)
    s1, c1 = sin(half1), cos(half1)
    sb, cb = sin(half234), cos(half234)
    sp, cp = sin(half_p), cos(half_p)
    sm, cm = sin(half_m), cos(half_m)
    sin2, cos2 = sin(q2), cos(q2)
    sin23, cos23 = sin(q23), cos(q23)
    x = cb * cm - sb * sp
    y = cb * sm - sb * cp
    z = cb * cp + sb * sm
    w = cb * sp + sb * cm
    k = 0.7071067811865476
    kc1, ks1 = k * c1, k * s1
    rw = kc1 * x + ks1 * y
    rx = kc1 * z + ks1 * w
    ry = ks1 * z - kc1 * w
    rz = ks1 * x - kc1 * y
    # Full angles from the half angles already at hand (double-angle and angle-sum formulas).
    cos1, sin1 = c1 * c1 - s1 * s1, 2.0 * s1 * c1
    cos234, sin234 = cb * cb - sb * sb, 2.0 * sb * cb
    cos5, sin5 = cp * cm - sp * sm, sp * cm + cp * sm
    d6_sin5 = d6 * sin5
    reach = a2 * cos2 + a3 * cos23 + d5 * sin234 - d6_sin5 * cos234
    offset = d4 + d6 * cos5
    px = cos1 * reach + sin1 * offset
    py = sin1 * reach - cos1 * offset
    pz = d1 + a2 * sin2 + a3 * sin23 - d5 * cos234 - d6_sin5 * sin234
    return rw, rx, ry, rz, px, py, pz


#: Poses per block in the array kernels: a block's temporaries (a few dozen rows of BLOCK floats) stay in the L2
#: cache, and each numpy call still covers enough elements to amortise its Python overhead (4096–8192 measured best).
BLOCK = 4096
_HALF_SQRT2 = 0.7071067811865476


def flange_rows(half_lengths, q1, q2, q3, q4, q5, q6, out=None) -> np.ndarray:
    """(7, *S) rows (rw, rx, ry, rz, ½px, ½py, ½pz): flange rotation and half position of a nominal UR arm.

    The closed form of :func:`flange_coefficients` (same symbols) for joint arrays: q2, q3, q4 of shape S, while q1 and
    q5, q6 (these two of one shape) may have fewer entries that broadcast to S (configurations sharing a joint
    value share its sines and cosines). Each step is one numpy call over every row it needs, temporaries reused
    in place (hot loop).
    ``out`` (7 arrays of shape S, optional) receives the rows.
    """
    d1, a2, a3, d4, d5, d6 = half_lengths
    # Half angles q234/2, full angles q2, q23, each halved once more for sincos_of_half's tangent.
    triple = np.empty((3,) + np.shape(q2))
    np.add(q2, q3, out=triple[2])
    np.add(triple[2], q4, out=triple[0])
    np.multiply(q2, 0.5, out=triple[1])
    triple[0] *= 0.25
    triple[2] *= 0.5
    (sb, sin2, sin23), (cb, cos2, cos23) = sincos_of_half(triple)
    s1, c1 = sincos_of_half(np.multiply(q1, 0.25))
    wrist = np.empty((2,) + np.shape(q5))
    np.add(q5, q6, out=wrist[0])
    np.subtract(q5, q6, out=wrist[1])
    wrist *= 0.25
    (sp, sm), (cp, cm) = sincos_of_half(wrist)       # P = (q5 + q6)/2, M = (q5 − q6)/2
    x = cb * cm
    x -= sb * sp
    y = cb * sm
    y -= sb * cp
    z = cb * cp
    z += sb * sm
    w = cb * sp
    w += sb * cm
    # Full angles from the half angles already at hand (double-angle and angle-sum formulas).
    cos1 = c1 * c1
    cos1 -= s1 * s1
    sin1 = s1 * c1
    sin1 *= 2.0
    cos234 = cb * cb
    cos234 -= sb * sb
    sin234 = sb * cb
    sin234 *= 2.0
    offset = cp * cm
    offset -= sp * sm
    offset *= d6
    offset += d4                     # δ = d4 + d6 c5 (halved lengths: ½δ)
    d6_sin5 = sp * cm
    d6_sin5 += cp * sm
    d6_sin5 *= d6
    c1 *= _HALF_SQRT2
    s1 *= _HALF_SQRT2
    rows = np.empty((7,) + x.shape) if out is None else out
    rw, rx, ry, rz, px, py, pz = rows
    np.multiply(c1, x, out=rw)
    rw += s1 * y
    np.multiply(c1, z, out=rx)
    rx += s1 * w
    np.multiply(s1, z, out=ry)
    ry -= c1 * w
    np.multiply(s1, x, out=rz)
    rz -= c1 * y
    reach = cos2 * a2
    reach += a3 * cos23
    reach += d5 * sin234
    reach -= d6_sin5 * cos234
    np.multiply(cos1, reach, out=px)
    px += sin1 * offset
    np.multiply(sin1, reach, out=py)
    py -= cos1 * offset
    np.multiply(sin2, a2, out=pz)
    pz += a3 * sin23
    pz -= d5 * cos234
    pz -= d6_sin5 * sin234
    pz += d1
    return rows


def dual_part_rows(rows, out) -> None:
    """The dual part ½p·r (4 rows into ``out``) of rows (r, ½p) (7 rows): a pure vector times r, written out."""
    rw, rx, ry, rz, px, py, pz = rows
    dw, dx, dy, dz = out
    np.multiply(px, rx, out=dw)
    dw += py * ry
    dw += pz * rz
    np.negative(dw, out=dw)
    np.multiply(px, rw, out=dx)
    dx += py * rz
    dx -= pz * ry
    np.multiply(py, rw, out=dy)
    dy -= px * rz
    dy += pz * rx
    np.multiply(px, ry, out=dz)
    dz -= py * rx
    dz += pz * rw
