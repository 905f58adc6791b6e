"""The closed-form batch kernel of nominal arms: the equations of `equations._branches` for many poses at
once (cross-checked against them by tests/kinematics/test_batch_kernels.py), and its FK filter."""
from __future__ import annotations

import math

import numpy as np

from ur3dq.dqarray import sincos_of_half
from ur3dq.kinematics.ur_fk import flange_rows
from ur3dq.kinematics.ur_ik.equations import _wrist_centre
from ur3dq.kinematics.ur_ik.geometry import (
    _CHORD_LIMIT,
    _HALF_SQRT2,
    _TWO_PI,
    DUPLICATE_TOLERANCE,
    ELBOW_NEAR_TOLERANCE,
    FK_TOLERANCE_M,
    WRIST_NEAR_TOLERANCE,
    _Geometry,
)


def _regular_branches(g: _Geometry, target: np.ndarray) -> tuple:
    """(branches (6, 8, B), exists (8, B), merged (B,), near_singular (B,)) of flange pairs (7, B), nominal model.

    The equations of _branches with everything shared that can be: θ1's two values once per pose, the wrist and
    the planar arm once per θ1, both θ5 signs from the same terms (the flip turns θ234 by π and negates θ5, so
    cos θ234·sin θ5 and sin θ234·sin θ5 stay), and cos θ234, sin θ234, sin θ5 from the reduced rotation's half
    angles instead of trigonometry. Branches are canonical and finite: one that does not exist (shoulder or elbow
    out of reach) holds its clamped values and ``exists`` is False for it (NaN would send numpy's vectorised tan
    of the FK filter down a slow path). Valid away from the wrist singularity only: ``near_singular`` marks the
    poses (|sin θ5/2| or |cos θ5/2| < WRIST_NEAR_TOLERANCE for some θ1, or |sin θ3| < ELBOW_NEAR_TOLERANCE) whose
    branches the caller must redo with _branches. ``merged``: poses whose θ1 or θ3 branches may coincide.
    """
    qw, qx, qy, qz, px, py, pz = target
    count = target.shape[1]
    x5, y5 = _wrist_centre(g, qw, qx, qy, qz, px, py)
    d4_2 = g.d4 * g.d4
    reach = x5 * x5
    reach += y5 * y5
    reach -= d4_2
    shoulder_reaches = reach >= -g.domain_slack * d4_2
    np.maximum(reach, 0.0, out=reach)
    offset = np.arctan2(np.sqrt(reach, out=reach), g.d4)
    base = np.arctan2(x5, -y5)
    theta1 = np.stack((base + offset, base - offset))
    # cos, sin of θ1/2 scaled by √½ (the Rx(−π/2) factor of the reduced rotation, eq. 4.14 ff.).
    sin_half1, cos_half1 = sincos_of_half(0.25 * theta1)
    cos1 = cos_half1 * cos_half1
    cos1 -= sin_half1 * sin_half1
    sin1 = sin_half1 * cos_half1
    sin1 *= 2.0
    cos_half1 *= _HALF_SQRT2
    sin_half1 *= _HALF_SQRT2
    # r' = Rx(−π/2)·Rz(−θ1)·r as in _reduced_rotation, with Rz(−θ1) = (c, 0, 0, −s).
    w1 = cos_half1 * qw + sin_half1 * qz
    x1 = cos_half1 * qx + sin_half1 * qy
    y1 = cos_half1 * qy - sin_half1 * qx
    z1 = cos_half1 * qz - sin_half1 * qw
    w, x, y, z = w1 + x1, x1 - w1, y1 + z1, z1 - y1
    sin_half5_2 = x * x
    sin_half5_2 += y * y
    cos_half5_2 = w * w
    cos_half5_2 += z * z
    sin_half5, cos_half5 = np.sqrt(sin_half5_2), np.sqrt(cos_half5_2)
    near_singular = np.any((sin_half5 < WRIST_NEAR_TOLERANCE) | (cos_half5 < WRIST_NEAR_TOLERANCE), axis=0)
    half_sum = np.arctan2(z, w)          # Σ/2, eqs. 4.14 and 4.16
    half_diff = np.arctan2(x, -y)        # Δ/2, eqs. 4.15 and 4.17
    theta5 = np.arctan2(sin_half5, cos_half5)
    theta5 *= 2.0
    # θ234 = Σ/2 + Δ/2: its cosine and sine times |w, z|·|x, y| (eqs. 4.14–4.17).
    cos234_scaled = w * y
    cos234_scaled += z * x
    np.negative(cos234_scaled, out=cos234_scaled)
    sin234_scaled = w * x
    sin234_scaled -= z * y
    # sin θ5 = 2·|x,y|·|w,z|/(|x,y|² + |w,z|²), so cos θ234·sin θ5 = 2·cos234_scaled/norm² (likewise for sin).
    norm2 = sin_half5_2
    norm2 += cos_half5_2
    np.divide(2.0 * g.d6, norm2, out=norm2)
    product = sin_half5
    product *= cos_half5
    np.divide(g.d5, product, out=product)
    # Planar arm target (x4, z4) for θ5 ≥ 0 and for the flipped wrist (eq. 4.34): axis 1 is the θ5 sign.
    reach_x = cos1 * px
    reach_x += sin1 * py
    reach_x += cos234_scaled * norm2
    reach_z = sin234_scaled * norm2
    reach_z += pz - g.d1
    wrist_x = sin234_scaled * product    # d5·sin θ234
    wrist_z = cos234_scaled * product    # d5·cos θ234
    x4 = np.stack((reach_x - wrist_x, reach_x + wrist_x), axis=1)
    z4 = np.stack((reach_z + wrist_z, reach_z - wrist_z), axis=1)
    cos3 = x4 * x4
    cos3 += z4 * z4
    cos3 -= g.a2 * g.a2 + g.a3 * g.a3
    cos3 *= 1.0 / (2.0 * g.a2 * g.a3)
    elbow_reaches = np.abs(cos3) <= 1.0 + g.domain_slack
    np.clip(cos3, -1.0, 1.0, out=cos3)
    sin3 = cos3 * cos3
    np.subtract(1.0, sin3, out=sin3)
    np.sqrt(sin3, out=sin3)
    theta3 = np.arctan2(sin3, cos3)
    # Near the stretched or folded elbow θ3 carries the rounding of cos θ3 divided by sin θ3: those poses are
    # redone with the very equations the single-pose solver uses, so both give the same branches there.
    near_singular |= np.any((sin3 < ELBOW_NEAR_TOLERANCE) & elbow_reaches, axis=(0, 1))
    near_singular &= shoulder_reaches
    along = cos3
    along *= g.a3
    along += g.a2
    across = sin3
    across *= g.a3
    near_x, near_z = x4 * along, z4 * along
    far_x, far_z = x4 * across, z4 * across

    columns = np.empty((6, 2, 2, 2, count))   # joint, θ1 sign, θ5 sign, θ3 sign, pose
    columns[0] = _wrap_in_place(theta1)[:, None, None]
    np.arctan2(near_z - far_x, near_x + far_z, out=columns[1, :, :, 0])
    np.arctan2(near_z + far_x, near_x - far_z, out=columns[1, :, :, 1])
    columns[2, :, :, 0] = theta3
    np.negative(theta3, out=columns[2, :, :, 1])
    # θ5 ∈ (0, π) away from the singularity: both signs are canonical as they are.
    columns[4, :, 0] = theta5[:, None]
    np.negative(columns[4, :, 0], out=columns[4, :, 1])
    theta6 = np.stack((half_sum - half_diff, half_sum - half_diff - math.pi), axis=1)
    columns[5] = _wrap_in_place(theta6)[:, :, None]
    theta234 = half_sum + half_diff
    columns[3, :, 0] = theta234[:, None]
    theta234 += math.pi
    columns[3, :, 1] = theta234[:, None]
    columns[3] -= columns[1]
    columns[3] -= columns[2]                 # θ4 = θ234 − θ2 − θ3, eq. 4.44
    _wrap_in_place(columns[3])
    exists = np.broadcast_to((elbow_reaches & shoulder_reaches[None, None, :])[:, :, None], (2, 2, 2, count))
    elbow_merged = (np.abs(theta3) < DUPLICATE_TOLERANCE) | (np.abs(theta3) > math.pi - DUPLICATE_TOLERANCE)
    merged = (offset < DUPLICATE_TOLERANCE) | np.any(elbow_merged & elbow_reaches, axis=(0, 1))
    return columns.reshape(6, 8, count), exists.reshape(8, count), merged, near_singular


def _wrap_in_place(angle: np.ndarray) -> np.ndarray:
    """Angles mapped into (−π, π] in place, as wrap_angle does (NaN stays NaN); returns ``angle``."""
    turns = angle * (1.0 / _TWO_PI)
    np.rint(turns, out=turns)
    turns *= _TWO_PI
    angle -= turns
    # Rounding can land a hair outside [−π, π]: fold the ends back (rarely needed, so tested first).
    low = angle <= -math.pi
    if low.any():
        angle[low] += _TWO_PI
    high = angle > math.pi
    if high.any():
        angle[high] -= _TWO_PI
    return angle


def _regular_fk_filter(g: _Geometry, columns: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(8, B) mask of the branches (6, 8, B) whose FK meets the TCP poses, given as pairs (7, B) (see _pair_rows):
    the thesis' filter (eq. 4.45).

    The model's closed-form FK (ur_fk.flange_rows) of every branch's final joint angles, composed with the
    TCP, against the pose asked for, with the tolerances of _within_fk_tolerance (a NaN branch fails).
    The branches come from _regular_branches, with one θ1 value per four (θ1 sign) and one θ5, θ6 per pair
    (θ1, θ5 signs): those values enter the FK once per group.
    """
    count = target.shape[1]
    joints = columns.reshape(6, 2, 2, 2, count)
    q1, q5, q6 = joints[0][:, :1, :1], joints[4][:, :, :1], joints[5][:, :, :1]
    flange = flange_rows(g.half_lengths, q1, joints[1], joints[2], joints[3], q5, q6).reshape(7, 8, count)
    return _flange_meets(g, flange, target[:, None, :])


def _joints_fk_filter(g: _Geometry, joints: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(M,) mask: whether the FK of joint columns (6, M), one configuration per pose, meets the TCP poses given as
    pairs (7, M): the filter of _regular_fk_filter for one branch per pose (ik_batch checks only its winners)."""
    return _flange_meets(g, flange_rows(g.half_lengths, *joints), target)


def _flange_meets(g: _Geometry, flange: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Mask of flange rows (7, *S) (rotation, ½ position) whose TCP is within the FK filter's tolerances of the
    target pairs (7, *S or broadcasting to it), with the tests of _within_fk_tolerance."""
    rotation, half_position = flange[:4], flange[4:]
    if g.tcp_offset is not None:
        rotation, half_position = _tool_rows(rotation, half_position, g.tcp_offset)
    error = half_position - 0.5 * target[4:]
    error *= error
    position_ok = error.sum(axis=0) <= (0.5 * FK_TOLERANCE_M) ** 2
    minus = rotation - target[:4]
    plus = rotation + target[:4]
    minus *= minus
    plus *= plus
    chord2 = np.minimum(minus.sum(axis=0), plus.sum(axis=0))   # the sign of σ ≡ −σ that is nearer
    return position_ok & (chord2 <= _CHORD_LIMIT ** 2)


def _tool_rows(rotation: np.ndarray, half_position: np.ndarray, tool) -> tuple:
    """(r·r_t, ½(p + r·t_t·r*)) rows of flange rows (r (4, M), ½p (3, M)) and a tool (r_t (4 floats), ½t_t (3))."""
    (tw, tx, ty, tz), (hx, hy, hz) = tool
    w, x, y, z = rotation
    composed = np.stack((w * tw - x * tx - y * ty - z * tz, w * tx + x * tw + y * tz - z * ty,
                         w * ty - x * tz + y * tw + z * tx, w * tz + x * ty - y * tx + z * tw))
    # v + 2w(u×v) + 2u×(u×v), u the vector part of r, v = ½t_t.
    cx, cy, cz = y * hz - z * hy, z * hx - x * hz, x * hy - y * hx
    moved = np.stack((hx + 2.0 * (w * cx + y * cz - z * cy), hy + 2.0 * (w * cy + z * cx - x * cz),
                      hz + 2.0 * (w * cz + x * cy - y * cx)))
    return composed, half_position + moved
