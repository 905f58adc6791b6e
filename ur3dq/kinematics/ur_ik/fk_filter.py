"""Pose input checks and the thesis' FK filter (eq. 4.45): a branch is a solution only if its FK meets the pose."""
from __future__ import annotations

import math

import numpy as np

from ur3dq import dqarray
from ur3dq.dualquat import DualQuaternion, multiply_quaternion_coefficients
from ur3dq.kinematics.ur_fk import flange_rotation_position, joint_floats
from ur3dq.kinematics.ur_ik.geometry import (
    _CHORD_LIMIT,
    _HALF_SQRT2,
    _TWO_PI,
    DUPLICATE_TOLERANCE,
    FK_TOLERANCE_M,
    _flange_of,
    _Geometry,
    _geometry,
    _translation_columns,
)
from ur3dq.real_numbers import real_array


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
            values = real_array(pose)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got {pose!r}") from exc
        if values.shape != (8,):
            raise ValueError(f"{name}: expected a DualQuaternion or 8 coefficients, got shape {values.shape}")
        c = tuple(values.tolist())
    rw, rx, ry, rz, dw, dx, dy, dz = c
    norm2 = rw * rw + rx * rx + ry * ry + rz * rz
    if not math.isfinite(norm2 + dw + dx + dy + dz):
        raise ValueError(f"{name}: contains NaN or infinite values")
    off_unit = abs(norm2 - 1.0)
    if off_unit > 2.0 * dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: rotation part is not a unit quaternion (norm² {norm2:.6g})")
    orthogonality = rw * dw + rx * dx + ry * dy + rz * dz
    if abs(orthogonality) > dqarray.UNIT_TOLERANCE:
        raise ValueError(f"{name}: not a unit dual quaternion (real·dual = {orthogonality:.3g}, must be 0)")
    if off_unit > _EXACT_UNIT or abs(orthogonality) > _EXACT_UNIT:
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
    return _nominal_check(g, q, _fk_target(tcp_coefficients))


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
    target = _fk_target(tcp_coefficients)
    return lambda q: _nominal_check(g, q, target)


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
    # Squares as products (as _nominal_meets, which must reach the very same floats, computes them).
    dw, dx, dy, dz, ex, ey, ez = rw - tw, rx - tx, ry - ty, rz - tz, fx - hx, fy - hy, fz - hz
    return (dw * dw + dx * dx + dy * dy + dz * dz <= _CHORD_LIMIT2
            and ex * ex + ey * ey + ez * ez <= _HALF_POSITION_LIMIT2)


#: _nominal_meets judges a branch from terms it shares with another when their joints relate as in _nominal_branches
#: within _SHARED_ANGLE (the same θ1, θ5, θ6 and θ2 + θ3 + θ4: the elbow partner; or the same θ1, θ5 negated and
#: θ234 ± θ6 the same or 2π apart: the wrist flip; the sums differ by the rounding of a few sums of angles, ~1e-15
#: rad) and its chord and half-position distance are at least _VERDICT_MARGIN clear of the limits. Its terms are
#: _nominal_check's in another arrangement (joint 1's frame, the shared angles): they differ from that check's by the
#: rounding of ~1 m sums (~1e-15) and at most ~2·_SHARED_ANGLE·(1 + |d5| + |d6|) (an elbow partner of a wrist flip)
#: ≪ the margin, so the verdict is that check's.
_SHARED_ANGLE = 1e-13
_VERDICT_MARGIN = 1e-12
#: Open bands of squared chord and squared half distance around the limits where a branch gets the general check.
_CHORD_BAND2 = ((_CHORD_LIMIT - _VERDICT_MARGIN) ** 2, (_CHORD_LIMIT + _VERDICT_MARGIN) ** 2)
_POSITION_BAND2 = ((0.5 * FK_TOLERANCE_M - _VERDICT_MARGIN) ** 2, (0.5 * FK_TOLERANCE_M + _VERDICT_MARGIN) ** 2)


def _nominal_meets(g: _Geometry, branches: list, target: tuple) -> list:
    """Per branch of single._nominal_branches (8 tuples of 6 floats, branch order, NaN where absent): whether it
    exists and meets ``target`` (_fk_target): the verdict of _nominal_check, computed with shared subexpressions.

    Branches 2k and 2k + 1 (the elbow pair) share θ1, θ5, θ6 (the same floats) and θ234 = θ2 + θ3 + θ4 (up to
    rounding); pairs 0–1 and 2–3 share θ1, and the second pair of a θ1 is the first's wrist flip (−θ5, θ6 ∓ π,
    θ234 ± π). Joints 2–4 are parallel, so the flange rotation depends on θ1, θ234, θ5, θ6 only, and the flip keeps
    it: it is compared once per θ1 (once per pair where the flip does not hold, as at a singular wrist), in joint 1's
    frame (the target turned by Rx(−π/2)·Rz(−θ1): a rotation keeps the chord), where the flange is the module notes'
    half-angle form w' = cos(θ5/2)·cos(Σ/2), x' = sin(θ5/2)·sin(Δ/2), y' = −sin(θ5/2)·cos(Δ/2), z' =
    cos(θ5/2)·sin(Σ/2) (Σ, Δ = θ234 ± θ6). The position error is taken in the arm plane (turned by −θ1) as reach,
    height and offset: the wrist's d5, d6 terms once per θ1 (the flip turns their signs), then each branch adds its
    planar 2-link term a2·(c2, s2) + a3·(c23, s23). A branch outside the _SHARED_ANGLE and _VERDICT_MARGIN argument
    (corrupted, unrelated to its neighbours, or within the margin of a limit) gets _nominal_check itself.
    Cross-checked against _nominal_check by tests/kinematics/test_ur_ik_filter.py.
    """
    d1, a2, a3, d4, d5, d6 = g.half_lengths
    tw, tx, ty, tz, hx, hy, hz = target
    tool = g.tcp_offset
    if tool is not None:   # |r·r_t ∓ t| = |r ∓ t·r_t*|: the tool's rotation moves to the target, once
        (ow, ox, oy, oz), (vx, vy, vz) = tool
        tw, tx, ty, tz = multiply_quaternion_coefficients((tw, tx, ty, tz), (ow, -ox, -oy, -oz))
    sin, cos, h = math.sin, math.cos, _HALF_SQRT2
    chord_low, position_low = _CHORD_BAND2[0], _POSITION_BAND2[0]
    verdicts = []
    # set by the first pair of each θ1 (else branch below) and read by its wrist flip, which always comes after it
    shoulder = flip5 = flip_sum = flip_diff = math.nan
    reach = height = wrist_along = wrist_up = tilt_along = tilt_up = math.nan
    for first, second in zip(branches[0::2], branches[1::2]):
        q1, q2, q3, q4, q5, q6 = first
        if not (q1 == q1 and q2 == q2):   # absent (NaN): the partner, if it exists, on its own
            verdicts += (False, _nominal_check(g, second, target))
            continue
        q234 = q2 + q3 + q4
        if (q1 == shoulder and q5 == -flip5 and abs(q234 + q6 - flip_sum) <= _SHARED_ANGLE
                and abs(abs(q234 - q6 - flip_diff) - _TWO_PI) <= _SHARED_ANGLE):
            # The wrist flip (−θ5, θ6 ∓ π, θ234 ± π) of this θ1's pair before: the same rotation (chord2) and offset
            # (across2); cos θ234, sin θ234 and sin θ5 change sign, so do the wrist terms.
            along, up = reach - wrist_along - tilt_along, height + wrist_up - tilt_up
        else:
            if q1 != shoulder:   # the target in joint 1's frame, as equations._reduced_rotation turns it
                shoulder = q1
                ch, sh = cos(0.5 * q1), -sin(0.5 * q1)
                w1, x1, y1, z1 = ch * tw - sh * tz, ch * tx - sh * ty, ch * ty + sh * tx, ch * tz + sh * tw
                rw, rx, ry, rz = h * (w1 + x1), h * (x1 - w1), h * (y1 + z1), h * (z1 - y1)
                cos1, sin1 = ch * ch - sh * sh, -2.0 * ch * sh
            flip5, flip_sum, flip_diff = q5, q234 + q6, q234 - q6
            half_sum, half_diff, half5 = 0.5 * flip_sum, 0.5 * flip_diff, 0.5 * q5
            sin_sum, cos_sum, sin_diff, cos_diff = sin(half_sum), cos(half_sum), sin(half_diff), cos(half_diff)
            sin_half5, cos_half5 = sin(half5), cos(half5)
            w, x, y, z = cos_half5 * cos_sum, sin_half5 * sin_diff, -sin_half5 * cos_diff, cos_half5 * sin_sum
            if w * rw + x * rx + y * ry + z * rz < 0.0:   # the chord against the nearer sign of the pose (σ ≡ −σ)
                dw, dx, dy, dz = w + rw, x + rx, y + ry, z + rz
            else:
                dw, dx, dy, dz = w - rw, x - rx, y - ry, z - rz
            chord2 = dw * dw + dx * dx + dy * dy + dz * dz
            # flange_rotation_position's position less the target, in the arm plane: along the reach, up, and
            # across it (the shoulder offset d4 + d6·cos θ5); each branch adds its planar 2-link term below.
            cos234, sin234 = cos_sum * cos_diff - sin_sum * sin_diff, sin_sum * cos_diff + cos_sum * sin_diff
            cos5, d6_sin5 = cos_half5 * cos_half5 - sin_half5 * sin_half5, d6 * (2.0 * sin_half5 * cos_half5)
            wrist_along, wrist_up, tilt_along, tilt_up = d5 * sin234, d5 * cos234, d6_sin5 * cos234, d6_sin5 * sin234
            reach, height = -(cos1 * hx + sin1 * hy), d1 - hz
            across = d4 + d6 * cos5 - (sin1 * hx - cos1 * hy)
            if tool is not None:   # _tool_floats' offset r·½t_t·r*, (x, y, z) → (along, up, across) in the plane
                cx, cy, cz = y * vz - z * vy, z * vx - x * vz, x * vy - y * vx
                reach += vx + 2.0 * (w * cx + y * cz - z * cy)
                height += vy + 2.0 * (w * cy + z * cx - x * cz)
                across += vz + 2.0 * (w * cz + x * cy - y * cx)
            across2 = across * across
            along, up = wrist_along - tilt_along + reach, height - wrist_up - tilt_up
        p1, p2, p3, p4, p5, p6 = second
        shared = p1 == q1 and p5 == q5 and p6 == q6 and abs(p2 + p3 + p4 - q234) <= _SHARED_ANGLE
        # Each branch's planar 2-link term (the elbow pair written out, as _nominal_branches solves it).
        q23, p23 = q2 + q3, p2 + p3
        first_along, first_up = a2 * cos(q2) + a3 * cos(q23) + along, a2 * sin(q2) + a3 * sin(q23) + up
        second_along, second_up = a2 * cos(p2) + a3 * cos(p23) + along, a2 * sin(p2) + a3 * sin(p23) + up
        first2 = first_along * first_along + first_up * first_up + across2
        second2 = second_along * second_along + second_up * second_up + across2
        if chord2 <= chord_low and first2 <= position_low and second2 <= position_low and shared:
            verdicts += (True, True)   # the rule: both clearly within the tolerances
        else:
            verdicts += (_clear_verdict(chord2, first2, g, first, target),
                         _clear_verdict(chord2, second2 if shared else math.nan, g, second, target))
    return verdicts


def _clear_verdict(chord2: float, distance2: float, g: _Geometry, branch: tuple, target: tuple) -> bool:
    """The FK filter's verdict on squared chord and half distance ``chord2``, ``distance2`` (_nominal_meets' shared
    terms) when they are _VERDICT_MARGIN clear of the limits; else (or for a NaN) _nominal_check of ``branch``."""
    chord_low, chord_high = _CHORD_BAND2
    position_low, position_high = _POSITION_BAND2
    if (chord2 <= chord_low or chord2 >= chord_high) and (distance2 <= position_low or distance2 >= position_high):
        return chord2 <= chord_low and distance2 <= position_low
    return _nominal_check(g, branch, target)


def _nominal_check(g: _Geometry, q: tuple, target: tuple) -> bool:
    """Whether the 6 floats ``q`` (NaN where the branch does not exist) exist and the nominal model's FK at them meets
    ``target`` (_fk_target): the FK filter of one configuration, the general form of _nominal_meets."""
    return (q[0] == q[0] and q[1] == q[1]
            and _flange_meets(flange_rotation_position(*g.half_lengths, *q), g.tcp_offset, target))


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
