"""The thesis' IK equations (seed 000, §4.3), written once for plain floats (one pose) and numpy arrays (batches)."""
from __future__ import annotations

import math

import numpy as np

from ur3dq.kinematics.ur_ik.geometry import (
    _HALF_SQRT2,
    _TWO_PI,
    WRIST_NEAR_TOLERANCE,
    WRIST_SINGULAR_TOLERANCE,
    _Geometry,
)


class _ScalarOps:
    """Plain-float math for single poses: no numpy object churn on the hot path."""

    sqrt = staticmethod(math.sqrt)
    atan2 = staticmethod(math.atan2)
    cos = staticmethod(math.cos)
    sin = staticmethod(math.sin)
    asin = staticmethod(math.asin)

    @staticmethod
    def where(condition, if_true, if_false):
        """Select like numpy.where, for floats."""
        return if_true if condition else if_false

    @staticmethod
    def clamp_or_nan(value, low, high, slack):
        """``value`` clipped into [low, high] if within ``slack`` of it, else NaN."""
        if value < low - slack or value > high + slack:
            return math.nan
        return min(max(value, low), high)

    @staticmethod
    def wrap(angle):
        """Angle into [−π, π] (either end: used for distances only; NaN stays NaN)."""
        return math.remainder(angle, _TWO_PI)

    any = staticmethod(bool)
    isnan = staticmethod(math.isnan)


class _ArrayOps:
    """numpy math over arrays of poses: every branch of every pose at once."""

    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)
    cos = staticmethod(np.cos)
    sin = staticmethod(np.sin)
    asin = staticmethod(np.arcsin)
    where = staticmethod(np.where)

    @staticmethod
    def clamp_or_nan(value, low, high, slack):
        """``value`` clipped into [low, high] where within ``slack`` of it, NaN elsewhere."""
        with np.errstate(invalid="ignore"):
            outside = (value < low - slack) | (value > high + slack)
        return np.where(outside, np.nan, np.clip(value, low, high))

    @staticmethod
    def wrap(angle):
        """Angles into [−π, π] (either end: used for distances only)."""
        return angle - _TWO_PI * np.round(angle / _TWO_PI)

    any = staticmethod(np.any)
    isnan = staticmethod(np.isnan)


def _wrist_centre(g: _Geometry, qw, qx, qy, qz, px, py):
    """(x5, y5) of the wrist centre p5 = p − d6·z6 in the base frame (z6 = third column of the flange rotation)."""
    z6x = 2.0 * (qx * qz + qw * qy)
    z6y = 2.0 * (qy * qz - qw * qx)
    return px - g.d6 * z6x, py - g.d6 * z6y


def _theta1_pair(ops, g: _Geometry, x5, y5):
    """The two θ1 (eqs. 4.10–4.11) solving x5·sin θ1 − y5·cos θ1 = d4; NaN when the wrist centre is too close."""
    d4 = g.d4
    radial2 = x5 * x5 + y5 * y5
    # cos of the shoulder offset angle = d4/ρ must be ≤ 1: ρ ≥ d4 (clamped within the domain slack).
    reach = ops.clamp_or_nan(radial2 - d4 * d4, g.domain_edge * d4 * d4, math.inf, g.domain_slack * d4 * d4)
    base = ops.atan2(x5, -y5)
    offset = ops.atan2(ops.sqrt(reach), d4)
    return base + offset, base - offset


def _theta1_floats(g: _Geometry, qw, qx, qy, qz, px, py):
    """The θ1 pair of _theta1_pair for one pose's floats (rotation qw…qz, position px, py), or None where no θ1
    exists: written out off the shoulder circle (single-pose hot path), the general clamp on and inside it."""
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    d4 = g.d4
    reach = x5 * x5 + y5 * y5 - d4 * d4
    if reach > g.domain_edge * d4 * d4:
        base, offset = math.atan2(x5, -y5), math.atan2(math.sqrt(reach), d4)
        return base + offset, base - offset
    theta1_pair = _theta1_pair(_ScalarOps, g, x5, y5)   # clamped within the domain slack, NaN beyond
    return None if theta1_pair[0] != theta1_pair[0] else theta1_pair


def _reduced_rotation(ops, theta1, qw, qx, qy, qz):
    """(cos θ1, sin θ1, (w', x', y', z')): r' = Rx(−π/2)·Rz(−θ1)·r, what wrist joints 2…6 must produce."""
    ch, sh = ops.cos(0.5 * theta1), -ops.sin(0.5 * theta1)
    # Rz(−θ1)·r, with Rz(−θ1) = (ch, 0, 0, sh).
    w1, x1, y1, z1 = ch * qw - sh * qz, ch * qx - sh * qy, ch * qy + sh * qx, ch * qz + sh * qw
    # Rx(−π/2)·(…), with Rx(−π/2) = (h, −h, 0, 0).
    h = _HALF_SQRT2
    reduced = (h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1))
    return ch * ch - sh * sh, -2.0 * ch * sh, reduced


def _wrist_pair(ops, reduced, theta6_ref):
    """(θ5, θ6, θ234) for θ5 ≥ 0 and for θ5 ≤ 0 (eqs. 4.13–4.28 in half-angle form); singular: θ6 = theta6_ref.

    Also returns the flags (singular at 0, singular at π, near-singular, nearer 0 than π) used by _branches.
    """
    w, x, y, z = reduced
    sin_half5 = ops.sqrt(x * x + y * y)
    cos_half5 = ops.sqrt(w * w + z * z)
    half_sum = ops.atan2(z, w)          # Σ/2 = (θ234 + θ6)/2, eqs. 4.14 and 4.16
    half_diff = ops.atan2(x, -y)        # Δ/2 = (θ234 − θ6)/2 for sin(θ5/2) > 0, eqs. 4.15 and 4.17
    at_zero = sin_half5 < WRIST_SINGULAR_TOLERANCE
    at_pi = cos_half5 < WRIST_SINGULAR_TOLERANCE
    singular = at_zero | at_pi
    theta5 = ops.where(at_zero, 0.0, ops.where(at_pi, math.pi, 2.0 * ops.atan2(sin_half5, cos_half5)))
    theta6 = ops.where(singular, theta6_ref, half_sum - half_diff)
    theta234 = ops.where(at_zero, 2.0 * half_sum - theta6,
                         ops.where(at_pi, 2.0 * half_diff + theta6, half_sum + half_diff))
    # −θ5 turns Δ/2 by π (x', y' change sign): the wrist flip θ6 − π, θ234 + π; one solution when singular.
    flipped = (-theta5, ops.where(singular, theta6, theta6 - math.pi),
               ops.where(singular, theta234, theta234 + math.pi))
    near = (sin_half5 < WRIST_NEAR_TOLERANCE) | (cos_half5 < WRIST_NEAR_TOLERANCE)
    return (theta5, theta6, theta234), flipped, (singular, near, sin_half5 < cos_half5)


def _reachable_wrist_family(ops, g: _Geometry, cos1, sin1, theta5, theta234, px, py, pz):
    """The θ234 nearest ``theta234`` at which the planar arm reaches, for fixed θ1 and θ5 (NaN if none does).

    Eq. 4.34 gives (x4, z4) = P − ρ·(sin ψ, −cos ψ) with P = (c1 px + s1 py, pz − d1), ρ = |(d5, d6 s5)|,
    ψ = θ234 − atan2(d6 s5, d5): a circle. The elbow must span R² + ρ² − 2ρR·sin(ψ − φ) (R, φ: polar form of P),
    between the folded and the stretched arm; the allowed ψ form arcs whose ends have sin(ψ − φ) = low or high.
    """
    near_x, near_z = cos1 * px + sin1 * py, pz - g.d1
    radius = ops.sqrt(near_x * near_x + near_z * near_z)
    phase = ops.atan2(near_z, near_x)
    offset = g.d6 * ops.sin(theta5)
    rho = ops.sqrt(g.d5 * g.d5 + offset * offset)
    beta = ops.atan2(offset, g.d5)
    longest, shortest = abs(g.a2) + abs(g.a3), abs(abs(g.a2) - abs(g.a3))
    base2 = radius * radius + rho * rho
    low = (base2 - longest * longest) / (2.0 * rho * radius)
    high = (base2 - shortest * shortest) / (2.0 * rho * radius)
    psi = theta234 - beta
    sine = ops.sin(psi - phase)
    best = psi
    best_distance = ops.where((sine >= low) & (sine <= high), 0.0, math.inf)
    for bound in (low, high):
        arc_end = ops.asin(ops.clamp_or_nan(bound, -1.0, 1.0, 0.0))
        for candidate in (phase + arc_end, phase + math.pi - arc_end):
            distance = abs(ops.wrap(candidate - psi))
            nearer = distance < best_distance     # False for NaN: an arc end that does not exist
            best = ops.where(nearer, candidate, best)
            best_distance = ops.where(nearer, distance, best_distance)
    return ops.where(best_distance < math.inf, best + beta, math.nan)


def _planar_arm(ops, g: _Geometry, cos1, sin1, theta5, theta234, px, py, pz):
    """(x4, z4): where joints 2–3 must put the frame-4 origin, in the shoulder plane (eqs. 4.33–4.34)."""
    c234, s234 = ops.cos(theta234), ops.sin(theta234)
    s5 = ops.sin(theta5)
    x4 = cos1 * px + sin1 * py - s234 * g.d5 + c234 * s5 * g.d6
    z4 = pz - g.d1 + c234 * g.d5 + s234 * s5 * g.d6
    return x4, z4


def _elbow_cosine(ops, g: _Geometry, x4, z4):
    """cos θ3 of eq. 4.38, clamped within rounding of ±1 (stretched / folded elbow), NaN when out of reach."""
    cos3 = (x4 * x4 + z4 * z4 - g.a2 * g.a2 - g.a3 * g.a3) / (2.0 * g.a2 * g.a3)
    return ops.clamp_or_nan(cos3, g.domain_edge - 1.0, 1.0 - g.domain_edge, g.domain_slack)


def _shoulder_elbow_pair(ops, g: _Geometry, x4, z4, cos3):
    """((θ2, θ3) with θ3 ≥ 0, (θ2, θ3) with θ3 ≤ 0): θ3 from eq. 4.38, θ2 from eq. 4.41."""
    sin3 = ops.sqrt(1.0 - cos3 * cos3)
    theta3 = ops.atan2(sin3, cos3)
    along = g.a2 + g.a3 * cos3
    across = g.a3 * sin3
    near_x, near_z = x4 * along, z4 * along
    far_x, far_z = x4 * across, z4 * across
    return ((ops.atan2(near_z - far_x, near_x + far_z), theta3),
            (ops.atan2(near_z + far_x, near_x - far_z), -theta3))


def _elbow_for_wrist(ops, g: _Geometry, cos1, sin1, wrist, flags, px, py, pz):
    """(θ6, θ234, x4, z4, cos θ3) of one wrist branch (eqs. 4.33–4.38), moved along a singular wrist's family.

    At (or near) a singular wrist only θ234 + θ6 (θ5 ≈ 0) or θ234 − θ6 (θ5 ≈ π) is well determined; a split the
    arm cannot reach is moved to the nearest reachable one, θ6 compensating; the FK filter judges the result.
    """
    theta5, theta6, theta234 = wrist
    singular, near, nearer_zero = flags
    x4, z4 = _planar_arm(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
    cos3 = _elbow_cosine(ops, g, x4, z4)
    move = singular | (near & ops.isnan(cos3))
    if ops.any(move):
        reachable = _reachable_wrist_family(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
        shift = ops.where(move, reachable - theta234, 0.0)
        theta234 = theta234 + shift
        theta6 = theta6 + ops.where(nearer_zero, -shift, shift)
        x4, z4 = _planar_arm(ops, g, cos1, sin1, theta5, theta234, px, py, pz)
        cos3 = _elbow_cosine(ops, g, x4, z4)
    return theta6, theta234, x4, z4, cos3


def _branches(ops, g: _Geometry, target, theta6_ref):
    """The 8 analytic branches (θ1…θ6 tuples, NaN where one does not exist), by (θ1, θ5, θ3) sign, + first."""
    qw, qx, qy, qz, px, py, pz = target
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    branches = []
    for theta1 in _theta1_pair(ops, g, x5, y5):
        cos1, sin1, reduced = _reduced_rotation(ops, theta1, qw, qx, qy, qz)
        upper, lower, flags = _wrist_pair(ops, reduced, theta6_ref)
        for wrist in (upper, lower):
            theta6, theta234, x4, z4, cos3 = _elbow_for_wrist(ops, g, cos1, sin1, wrist, flags, px, py, pz)
            for theta2, theta3 in _shoulder_elbow_pair(ops, g, x4, z4, cos3):
                theta4 = theta234 - theta2 - theta3   # eq. 4.44
                branches.append((theta1, theta2, theta3, theta4, wrist[0], theta6))
    return branches


def wrap_angle(angle):
    """Angle(s) mapped into (−π, π] (radians; floats or arrays, NaN stays NaN)."""
    angle = np.asarray(angle, dtype=float)
    wrapped = angle - _TWO_PI * np.rint(angle / _TWO_PI)
    # Rounding can land a hair outside [−π, π]: fold the ends back so the interval is exactly (−π, π].
    wrapped = np.where(wrapped <= -math.pi, wrapped + _TWO_PI, wrapped)
    return np.where(wrapped > math.pi, wrapped - _TWO_PI, wrapped)


def _wrap_float(angle: float) -> float:
    """A float angle mapped into (−π, π] (IEEE remainder: exact, then −π moved to π)."""
    wrapped = math.remainder(angle, _TWO_PI)
    return wrapped + _TWO_PI if wrapped <= -math.pi else wrapped
